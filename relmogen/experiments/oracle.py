"""``relmogen oracle``: scripted (or random) subgoal policies over many episodes."""

from __future__ import annotations

from pathlib import Path

from relmogen.agents.oracles import make_policy
from relmogen.envs.relmogen_env import RelmogenEnv
from relmogen.envs.subgoal_controls import SubgoalRControl
from relmogen.experiments.rollout import aggregate, run_episode, run_episodes
from relmogen.experiments.video import VIDEO_FPS, AnnotatedRecorder
from relmogen.motion_generation.arm import ArmConfig
from relmogen.simulation.views import check_animation_path, write_animation

ORACLE_CONTROLS = ("subgoal-r", "subgoal-d")


def run_oracle(task: str, episodes: int, policy: str = "oracle", control: str = "subgoal-r", seed: int = 0,
               scene: str | None = None, base_planner: str = "rrt_connect", arm_planner: str = "rrt_connect",
               arm_collision: bool = True, quiet: bool = False, video: Path | None = None, image_size: int = 128,
               push_frame: str = "base", qmap_size: int | None = None, robot: str = "fetch",
               arm_collision_backend: str | None = None) -> dict:
    """Oracles decide in ``subgoal-r`` actions. Through ``control="subgoal-d"`` each one is
    executed as the nearest discrete action (``SubgoalDControl.nearest_index``): the ceiling of
    SGP-D's action space at that image size and push frame. ``video`` (.gif or .mp4) records one
    more episode with the evaluation's overlays (``relmogen.experiments.video``)."""
    if video is not None:
        check_animation_path(video)
    if control not in ORACLE_CONTROLS:
        raise ValueError(f"oracles act through {' or '.join(ORACLE_CONTROLS)}, got control {control!r}")
    if control == "subgoal-d" and policy != "oracle":
        raise ValueError("random subgoal-d actions are measured by "
                         "relmogen analyse random-sgpd "
                         "(uniform over the allowed actions, as relmogen-d explores)")
    options = {"push_frame": push_frame, "qmap_size": qmap_size} if control == "subgoal-d" else {}
    arm_collision_backend = arm_collision_backend or ArmConfig.collision_backend
    env = RelmogenEnv(task=task, control=control, scene=scene, base_planner=base_planner, arm_planner=arm_planner,
                      arm_collision=arm_collision, arm_collision_backend=arm_collision_backend, image_size=image_size,
                      robot=robot, **options)
    agent = make_policy(policy, env)
    act = agent.act if control == "subgoal-r" else (lambda obs: env.control.nearest_index(agent.act(obs)))
    records = run_episodes(env, act, episodes, seed, quiet, on_reset=agent.reset,
                           description=f"{task} {policy}")
    if control == "subgoal-d":
        options["qmap_size"] = env.control.q
    result = {"task": task, "policy": policy, "control": control, "image_size": image_size, **options,
              "robot": robot, "scene": env.scene.name, "base_planner": base_planner, "arm_planner": arm_planner,
              "arm_collision": arm_collision, "arm_collision_backend": arm_collision_backend, **aggregate(records)}
    if video is not None:
        recorder = AnnotatedRecorder()
        run_episode(env, act, seed, on_reset=agent.reset, recorder=recorder)
        result["video"] = str(write_animation(recorder.frames, video, fps=VIDEO_FPS))
    env.close()
    return result


def oracle_arm_pushes(env: RelmogenEnv, episodes: int, seed: int):
    """Let the task's oracle drive ``env`` for up to ``episodes`` episodes (seeds ``seed``, ``seed``
    + 1, ...) and yield ``(episode, step, obs, action)`` just before each of its arm pushes,
    with the world in that state. The oracle acts through a ``subgoal-r`` control on the same
    world (same planners); ``env``'s own control is put back before every observation, so
    ``obs`` and its masks are what a policy of that control would see."""
    unwrapped = env.unwrapped
    own_control = unwrapped.control
    planners = own_control.mg.config
    oracle_control = SubgoalRControl(unwrapped, base_planner=planners.base_planner,
                                     arm_planner=planners.arm_planner, arm_collision=planners.arm_collision_checking)
    oracle = make_policy("oracle", unwrapped)
    for episode in range(episodes):
        obs, _ = env.reset(seed=seed + episode)
        oracle.reset()
        done, step = False, 0
        while not done:
            action = oracle.act(obs)
            if not oracle_control.uses_base(action):
                yield episode, step, obs, action
            unwrapped.control = oracle_control
            try:
                _, _, terminated, truncated, _ = env.step(action)
            finally:
                unwrapped.control = own_control
            obs = unwrapped._observe()
            done, step = terminated or truncated, step + 1
