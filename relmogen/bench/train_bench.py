"""``relmogen bench train``: gradient updates per second and environment steps per second.

For each algorithm and preset: the model is built exactly as ``relmogen train`` builds it,
its replay buffer is filled with real transitions (a few collected ones, repeated up to one
batch), then ``model.train`` is timed for ``updates`` gradient steps. Environment steps per
second are measured on one environment of the preset's image size with random actions (a
preset's ``n_envs`` workers run these in parallel). For SGP-R the same update is also timed
with SB3's stock SAC (separate encoders for actor, critic and target), which is the cost our
shared encoder avoids. For SGP-D the replay memory is reported too (bytes of the allocated
arrays, per 1e4 transitions and at the preset's buffer size), and the update cost at each
(image size, Q-map side) of ``QMAP_SETTINGS`` and in float32 against bfloat16 autocast
(``algo.qmap_bf16``), both only with ``probes``. ``qmap_variants`` times the relmogen-d update of
each Q-map network of ``QMAP_VARIANTS`` (NCHW against channels-last layout, the cheaper
``QMAP_LITE`` network), alternated in one process so that the ratios hold on a shared machine.
``bench_sac_update_variants`` (relmogen-r, the steps of issue 58) and
``bench_qmap_update_allocator`` (relmogen-d, glibc's malloc thresholds against
``relmogen.agents.allocator.keep_freed_memory``) time variants of one update in forked children
(``forked_update_ab``); the second runs with ``probes`` (about 30 s), the first is called alone.
Then one real training run each of relmogen-r and relmogen-d (and with ``probes`` of relmogen-d
under bfloat16; ``bench_training_run``) gives episodes per CPU-hour. The CLI adds ``host``
(``relmogen.experiments.host``): figures from different host kinds differ 2.5-3x.
"""

from __future__ import annotations

import time

import numpy as np
import torch as th
from stable_baselines3 import SAC
from stable_baselines3.common.vec_env import DummyVecEnv

from relmogen.agents.networks import SGPREncoder
from relmogen.envs.relmogen_env import RelmogenEnv
from relmogen.experiments.config import resolve_config
from relmogen.experiments.environments import env_kwargs
from relmogen.experiments.models import build_model

ALGOS = ("relmogen-r", "sac", "relmogen-d")
COLLECTED = 16  # real transitions per benchmark; repeated to fill one batch


def _vec_env(config) -> DummyVecEnv:
    kwargs = env_kwargs(config, arm_collision=config.env.arm_collision_train)
    return DummyVecEnv([lambda: RelmogenEnv(**kwargs)])


def _fill_buffer(model, batch_size: int) -> float:
    """Collect transitions with random actions; returns env steps per second."""
    env = model.get_env()  # SB3's wrapped env (images transposed as the model expects)
    obs = env.reset()
    transitions, start = [], time.perf_counter()
    for _ in range(COLLECTED):
        action = np.array([env.action_space.sample()])
        next_obs, reward, done, infos = env.step(action)
        transitions.append((obs, next_obs, action, reward, done, infos))
        obs = next_obs
    steps_per_second = COLLECTED / (time.perf_counter() - start)
    for index in range(max(batch_size, COLLECTED)):
        model.replay_buffer.add(*transitions[index % COLLECTED])
    return steps_per_second


def _time_updates(model, updates: int, batch_size: int) -> tuple[float, float]:
    """Wall and CPU (this process) seconds per gradient update."""
    model.train(gradient_steps=1, batch_size=batch_size)  # warm-up (allocations, first kernels)
    wall, cpu = time.perf_counter(), time.process_time()
    model.train(gradient_steps=updates, batch_size=batch_size)
    return (time.perf_counter() - wall) / updates, (time.process_time() - cpu) / updates


def _updates_per_second(model, updates: int, batch_size: int) -> float:
    return 1.0 / _time_updates(model, updates, batch_size)[0]


def _stock_sac(config, env):
    params = config.algo_params
    return SAC("MultiInputPolicy", env, buffer_size=params.buffer_size, batch_size=params.batch_size,
               learning_starts=0, policy_kwargs=dict(features_extractor_class=SGPREncoder, normalize_images=False,
                                                     net_arch=params.net_arch), device="cpu", seed=0)


def _model_with_replay(task: str, algo: str, preset: str, seed: int = 0, overrides: tuple[str, ...] = ()):
    """(config, vectorised env, model with one batch of real transitions, env steps per second)."""
    config = resolve_config(task, algo, seed=seed, preset=preset, overrides=list(overrides))
    env = _vec_env(config)
    model = build_model(config, env)
    model._setup_learn(total_timesteps=1)  # creates the logger that train() records into
    return config, env, model, _fill_buffer(model, config.algo_params.batch_size)


def bench_one(task: str, algo: str, preset: str, updates: int, seed: int = 0, overrides: tuple[str, ...] = ()) -> dict:
    config, env, model, env_sps = _model_with_replay(task, algo, preset, seed, overrides)
    batch = config.algo_params.batch_size
    wall_s, cpu_s = _time_updates(model, updates, batch)
    result = {"task": task, "algo": algo, "preset": preset, "image_size": config.env.image_size,
              "batch_size": batch, "env_steps_per_s": round(env_sps, 3), "updates_per_s": round(1.0 / wall_s, 3),
              "update_cpu_s": round(cpu_s, 4)}
    if algo == "relmogen-r":
        stock = _stock_sac(config, env)
        stock._setup_learn(total_timesteps=1)
        _fill_buffer(stock, batch)
        result["stock_sb3_sac_updates_per_s"] = round(_updates_per_second(stock, updates, batch), 3)
        result["shared_encoder_speedup"] = round(result["updates_per_s"] / result["stock_sb3_sac_updates_per_s"], 3)
    if algo == "relmogen-d":
        result["qmap_size"] = model.q
        buffer = model.replay_buffer
        result["replay_gib_per_1e4_transitions"] = round(buffer.nbytes() / buffer.buffer_size * 1e4 / 2**30, 4)
        result["replay_gib_at_preset_size"] = round(buffer.nbytes() / 2**30, 4)
    env.close()
    return result


def bench_train(task: str = "PushDoorNav", updates: int = 10, advance=None, subgoals: int = 1000,
                probes: bool = False) -> dict:
    """The update and step rates of every algorithm with the ``cpu`` preset, the relmogen-d
    update of each Q-map network layout alternated in one process (``qmap_variants``), then one
    real ``cpu`` training run each of relmogen-r and relmogen-d (see ``bench_training_run``).
    ``probes`` adds the ``paper`` preset (128 px), the Q-map resolutions, bfloat16 (which take
    most of an hour on a CPU without native bfloat16) and the relmogen-d update under glibc's own
    malloc thresholds against ``keep_freed_memory`` (``bench_qmap_update_allocator``)."""
    presets = ("cpu", "paper") if probes else ("cpu",)
    runs = []
    for preset in presets:
        for algo in ALGOS:
            runs.append(bench_one(task, algo, preset, updates))
            if advance is not None:
                advance()
    result = {"task": task, "updates_timed": updates, "runs": runs,
              "qmap_variants": bench_qmap_variants(task, updates)}
    training_run = bench_training_run(task, "cpu", subgoals)
    training_run_d = bench_training_run(task, "cpu", subgoals, algo="relmogen-d")
    training_run_d_lite = bench_training_run(task, "cpu", subgoals, algo="relmogen-d", overrides=QMAP_LITE)
    result.update({"training_run": training_run, "training_run_relmogen_d": training_run_d,
                   "training_run_relmogen_d_lite": training_run_d_lite,
                   "episodes_per_cpu_hour": training_run["episodes_per_cpu_hour"],
                   "subgoals_per_cpu_s": training_run["subgoals_per_cpu_s"],
                   "relmogen_d_episodes_per_cpu_hour": training_run_d["episodes_per_cpu_hour"],
                   "relmogen_d_lite_episodes_per_cpu_hour": training_run_d_lite["episodes_per_cpu_hour"]})
    if probes:
        training_run_d_bf16 = bench_training_run(task, "cpu", subgoals, algo="relmogen-d", overrides=BF16)
        result.update({"qmap_resolutions": bench_qmap_resolutions(task, updates),
                       "qmap_precisions": bench_qmap_precisions(task, updates),
                       "qmap_update_allocator": bench_qmap_update_allocator(task, updates),  # ~30 s
                       "training_run_relmogen_d_bf16": training_run_d_bf16,
                       "relmogen_d_bf16_episodes_per_cpu_hour": training_run_d_bf16["episodes_per_cpu_hour"]})
    return result


# The cheaper Q-map network under test (issue 58): half the branch widths at high resolution, a
# 32-channel head and a 2x2 last upsampling
QMAP_LITE = ("algo.qmap_widths=[16,32,64,64]", "algo.qmap_head_width=32", "algo.qmap_head_kernel=2")
QMAP_VARIANTS = {  # name: (overrides, channels-last layout)
    "plain_layout": ((), False),  # the code before 2026-12-07: NCHW tensors
    "channels_last": ((), True),
    "skip_plain_layout": (("algo.qmap_skip=true",), False),
    "skip_channels_last": (("algo.qmap_skip=true",), True),
    "lite": (QMAP_LITE, True),
    "skip_lite": (("algo.qmap_skip=true", *QMAP_LITE), True),
}


def use_plain_layout(net) -> None:
    """Put a ``QMapNetwork`` back in the NCHW layout it had before it ran channels-last (weights
    and inputs), for the A/B of ``bench_qmap_variants``; its Q values stay the same."""
    from relmogen.agents.qmap_network import QMapNetwork

    net.to(memory_format=th.contiguous_format)
    net.image_tensor = lambda obs: QMapNetwork.image_tensor(net, obs).contiguous()
    net.map_tensor = lambda obs: QMapNetwork.map_tensor(net, obs).contiguous()


def bench_qmap_variants(task: str, updates: int, rounds: int = 3, preset: str = "cpu") -> list[dict]:
    """relmogen-d update CPU seconds per batch of each ``QMAP_VARIANTS`` network, the variants
    alternated ``rounds`` times in this process (the median counts), each against ``plain_layout``."""
    models = {}
    for name, (overrides, channels_last) in QMAP_VARIANTS.items():
        config, env, model, _ = _model_with_replay(task, "relmogen-d", preset, overrides=overrides)
        if not channels_last:
            use_plain_layout(model.q_net.net)
            use_plain_layout(model.q_net_target.net)
        models[name] = (config, env, model)
    seconds = {name: [] for name in models}
    for _ in range(rounds):
        for name, (config, _, model) in models.items():
            seconds[name].append(_time_updates(model, updates, config.algo_params.batch_size)[1])
    rows = []
    for name, (config, env, model) in models.items():
        env.close()
        rows.append({"variant": name, "overrides": list(QMAP_VARIANTS[name][0]), "qmap_size": model.q,
                     "parameters": sum(p.numel() for p in model.q_net.parameters()),
                     "update_cpu_s": round(float(np.median(seconds[name])), 4)})
    baseline = {row["variant"]: row["update_cpu_s"] for row in rows}
    for row in rows:
        reference = "skip_plain_layout" if row["variant"].startswith("skip") else "plain_layout"
        row["speedup_vs_plain_layout"] = round(baseline[reference] / row["update_cpu_s"], 3)
    return rows


def sac_step_before_issue_58(self, data, logs: dict[str, list[float]]) -> None:
    """``SharedEncoderSAC._gradient_step`` as it was before issue 58 (SB3's ``extract_features``
    for each encoder pass, the actor loss back-propagated into the critic's weights too, SB3's
    ``polyak_update``): the reference of ``bench_sac_update_variants`` and of
    tests/agents/test_sac_update_equivalence.py, which checks that today's step equals it bit for bit."""
    from stable_baselines3.common.utils import polyak_update

    from relmogen.agents.sac import augmented

    critic, target = self.critic, self.critic_target
    with augmented([critic.features_extractor, target.features_extractor]):
        features = critic.extract_features(data.observations, critic.features_extractor)
        with th.no_grad():
            next_features = critic.extract_features(data.next_observations, critic.features_extractor)
            next_target_features = target.extract_features(data.next_observations, target.features_extractor)
    actions_pi, log_prob, ent_coef = self._critic_update(data, features, next_features, next_target_features, logs)
    actor_loss = self._actor_loss(features, actions_pi, log_prob, ent_coef, logs)
    self.actor.optimizer.zero_grad()
    actor_loss.backward()
    self.actor.optimizer.step()
    polyak_update(self.critic.parameters(), self.critic_target.parameters(), self.tau)


SAC_UPDATE_VARIANTS = {  # name: (the step before issue 58, glibc keeps freed memory)
    "before": (True, False),
    "before_kept_memory": (True, True),
    "step_only": (False, False),
    "after": (False, True),
}


def forked_update_ab(model, batch_size: int, variants: dict, updates: int, rounds: int) -> list[dict]:
    """Update CPU seconds (median) and page faults per update of ``model`` under each of
    ``variants`` (name: a function that prepares the model and the process), each against the
    first (``speedup_vs_<first>``: the median over ``rounds`` of the per-round ratio). glibc's
    thresholds move with a process's history and cannot be put back once set, so each round forks
    one child per variant from this process (one model and replay, warmed up under glibc's own
    thresholds, which this process keeps: ``keep_freed_memory_once`` is disabled here while it
    runs); the variants start from the same memory state and alternate, in a rotating order, on a
    shared machine. Linux only."""
    import json
    import os
    import resource

    from relmogen.agents import allocator

    kept_before, allocator._kept_freed_memory = allocator._kept_freed_memory, True
    try:
        model.train(gradient_steps=3, batch_size=batch_size)  # lazy fits (input scaling); allocations settle
        names = list(variants)
        seconds = {name: [] for name in names}
        faults = {name: [] for name in names}
        for round_index in range(rounds):
            for name in names[round_index % len(names):] + names[:round_index % len(names)]:
                read, write = os.pipe()
                child = os.fork()
                if child == 0:  # measure, report through the pipe, leave without any clean-up
                    try:
                        os.close(read)
                        variants[name](model)
                        model.train(gradient_steps=2, batch_size=batch_size)  # copy-on-write faults go here
                        start = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
                        cpu_s = _time_updates(model, updates, batch_size)[1]
                        minflt = (resource.getrusage(resource.RUSAGE_SELF).ru_minflt - start) / (updates + 1)
                        os.write(write, json.dumps([cpu_s, minflt]).encode())
                    finally:
                        os._exit(0)
                os.close(write)
                with os.fdopen(read) as pipe:
                    cpu_s, minflt = json.loads(pipe.read())
                os.waitpid(child, 0)
                seconds[name].append(cpu_s)
                faults[name].append(minflt)
    finally:
        allocator._kept_freed_memory = kept_before
    rows = [{"variant": name, "update_cpu_s": round(float(np.median(seconds[name])), 4),
             "page_faults_per_update": round(float(np.median(faults[name])))} for name in names]
    for row in rows:
        ratios = [b / s for b, s in zip(seconds[names[0]], seconds[row["variant"]])]  # per round
        row[f"speedup_vs_{names[0]}"] = round(float(np.median(ratios)), 3)
    return rows


def bench_sac_update_variants(task: str = "PushDoorNav", updates: int = 10, rounds: int = 5,
                              preset: str = "cpu") -> list[dict]:
    """relmogen-r update CPU seconds (and page faults) per batch of each ``SAC_UPDATE_VARIANTS``,
    each against ``before`` (median over ``rounds`` of the per-round ratio), one forked child per
    variant and round (``forked_update_ab``). Linux only."""
    import types

    from relmogen.agents.allocator import keep_freed_memory

    def variant(before: bool, kept: bool):
        def prepare(model) -> None:
            if kept:
                keep_freed_memory()
            if before:
                model._gradient_step = types.MethodType(sac_step_before_issue_58, model)
        return prepare

    config, env, model, _ = _model_with_replay(task, "relmogen-r", preset)
    try:
        return forked_update_ab(model, config.algo_params.batch_size,
                                {name: variant(*flags) for name, flags in SAC_UPDATE_VARIANTS.items()},
                                updates, rounds)
    finally:
        env.close()


def bench_qmap_update_allocator(task: str = "PushDoorNav", updates: int = 10, rounds: int = 5,
                                preset: str = "cpu") -> list[dict]:
    """relmogen-d update CPU seconds (and page faults) per batch under glibc's own malloc
    thresholds (``glibc_default``) and with ``relmogen.agents.allocator.keep_freed_memory``, one
    forked child per variant and round (``forked_update_ab``); ``speedup_vs_glibc_default`` is the
    median of the per-round ratios. Linux only."""
    from relmogen.agents.allocator import keep_freed_memory

    variants = {"glibc_default": lambda model: None, "keep_freed_memory": lambda model: keep_freed_memory()}
    config, env, model, _ = _model_with_replay(task, "relmogen-d", preset)
    try:
        return forked_update_ab(model, config.algo_params.batch_size, variants, updates, rounds)
    finally:
        env.close()


QMAP_SETTINGS = ((64, 16), (64, 32), (128, 32))  # (image px, Q): the old cpu head, the cpu preset, the paper's


def bench_qmap_resolutions(task: str, updates: int, preset: str = "cpu") -> list[dict]:
    """relmogen-d update cost per batch (``update_cpu_s``: CPU seconds, the preset's network and
    batch) at each (image, Q) of ``QMAP_SETTINGS``, each against the first in the same process."""
    rows = [bench_one(task, "relmogen-d", preset, updates,
                      overrides=(f"env.image_size={image}", f"env.qmap_size={q}")) for image, q in QMAP_SETTINGS]
    for row in rows:  # CPU time: the machine may be shared, and the learner runs one torch thread
        row["update_cost_vs_64px_q16"] = round(row["update_cpu_s"] / rows[0]["update_cpu_s"], 3)
    return rows


BF16 = ("algo.qmap_bf16=true",)


def bench_qmap_precisions(task: str, updates: int, preset: str = "cpu") -> list[dict]:
    """relmogen-d update cost per batch in float32 and under bfloat16 autocast (``algo.qmap_bf16``),
    the preset's network with the skip head, in the same process."""
    skip = ("algo.qmap_skip=true",)
    rows = [bench_one(task, "relmogen-d", preset, updates, overrides=skip + extra) for extra in ((), BF16)]
    for row, bf16 in zip(rows, (False, True)):
        row["qmap_bf16"] = bf16
        row["update_cost_vs_float32"] = round(row["update_cpu_s"] / rows[0]["update_cpu_s"], 3)
    return rows


# ------------------------------------------------------------------ a real training run
class _Stopwatch:
    """Wall seconds spent inside wrapped callables, per name."""

    def __init__(self):
        self.seconds: dict[str, float] = {}

    def wrap(self, name: str, function):
        def timed(*args, **kwargs):
            start = time.perf_counter()
            try:
                return function(*args, **kwargs)
            finally:
                self.seconds[name] = self.seconds.get(name, 0.0) + time.perf_counter() - start
        return timed


def bench_training_run(task: str = "PushDoorNav", preset: str = "cpu", subgoals: int = 1000,
                       out: str | None = None, algo: str = "relmogen-r", overrides: tuple[str, ...] = ()) -> dict:
    """One ``relmogen train`` run of ``algo`` (trainer and environment workers as training
    makes them) for about ``subgoals`` subgoals past the preset's ``learning_starts``. CPU time
    (psutil, the process tree) and the trainer's wall-clock shares are counted from the first
    gradient update to the end of learning, so they describe the steady state of a long run."""
    import tempfile
    from pathlib import Path

    from relmogen.experiments.environments import make_training_env
    from relmogen.experiments.session import learn
    from relmogen.experiments.train import new_run_dir

    config = _bench_run_config(task, preset, subgoals, algo, overrides)
    with tempfile.TemporaryDirectory(dir=out) as folder:
        run_dir = new_run_dir(Path(folder), config)
        model = build_model(config, make_training_env(config))
        watch, marks = _Stopwatch(), {}
        monitor_class = _time_the_run(model, watch, marks)
        learn(run_dir, config, model, {"episodes": 0, "timesteps": 0, "wall_time_s": 0.0}, quiet=True,
              monitor_class=monitor_class)
        episodes = _episodes_after(run_dir / "episodes.csv", marks["start"][2])
    (cpu_start, wall_start, steps_start), (cpu_end, wall_end, steps_end, seconds) = marks["start"], marks["end"]
    cpu, wall, steps = cpu_end - cpu_start, wall_end - wall_start, steps_end - steps_start
    return {
        "task": task, "algo": algo, "preset": preset, "n_envs": config.env.n_envs, "overrides": list(overrides),
        "torch_threads": config.run.torch_threads,
        **({"qmap_size": model.q} if algo == "relmogen-d" else {}),
        "subgoals_timed": int(steps), "episodes_timed": episodes, "cpu_s": round(cpu, 2), "wall_s": round(wall, 2),
        "subgoals_per_cpu_s": round(steps / cpu, 3),
        "episodes_per_cpu_hour": round(episodes / cpu * 3600, 1),
        "episodes_per_cpu_hour_at_25_subgoals": round(steps / 25 / cpu * 3600, 1),
        "time_shares": {name: round(value / wall, 3) for name, value in seconds.items()},
    }


def _bench_run_config(task: str, preset: str, subgoals: int, algo: str = "relmogen-r", overrides: tuple[str, ...] = ()):
    from relmogen.tasks import task_class

    config = resolve_config(task, algo, preset=preset, episodes=1,
                            overrides=["run.eval_every_episodes=1000000", *overrides])
    length = config.env.episode_steps or task_class(task).subgoal_steps  # random policies rarely end early
    return config.model_copy(update={"episodes": -(-(config.algo_params.learning_starts + subgoals) // length)})


def _time_the_run(model, watch: _Stopwatch, marks: dict):
    """Time updates, environment steps and checkpoints; mark CPU, wall time and subgoals at the
    first update (``start``) and at the end of learning, before the workers are closed (``end``).
    Returns the ``TrainingMonitor`` class that times checkpoints and marks the end."""
    from relmogen.experiments.budgets import process_tree_cpu_seconds
    from relmogen.experiments.monitor import TrainingMonitor

    def now(steps: int) -> tuple[float, float, int]:
        return process_tree_cpu_seconds(), time.perf_counter(), steps

    class TimedModel(type(model)):  # a class swap, not an attribute: checkpoints pickle attributes
        def train(self, *args, **kwargs):
            if "start" not in marks:
                marks["start"] = now(self.num_timesteps)
                watch.seconds.clear()
            return watch.wrap("update", super().train)(*args, **kwargs)

    class TimedMonitor(TrainingMonitor):
        def checkpoint(self, with_replay: bool = True) -> None:
            watch.wrap("checkpoint", super().checkpoint)(with_replay)

        def _on_training_end(self) -> None:
            marks["end"] = (*now(self.model.num_timesteps), dict(watch.seconds))
            super()._on_training_end()

    model.__class__ = TimedModel
    model.env.step = watch.wrap("environment", model.env.step)
    return TimedMonitor


def _episodes_after(episodes_csv, timesteps: int) -> int:
    import csv

    with open(episodes_csv, newline="") as handle:
        return sum(1 for row in csv.DictReader(handle) if int(row["timesteps"]) > timesteps)
