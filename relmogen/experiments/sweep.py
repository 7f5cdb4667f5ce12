"""``relmogen sweep``: every (task, algorithm, seed) as one training run, on Ray or one by one.

Each run is a run directory made exactly as ``relmogen train`` makes it (``train`` /
``resume`` of ``relmogen.experiments.train``), under ``DIR/runs/``. ``DIR/sweep.json`` (the
manifest, written atomically, by the sweep's driver only) holds the sweep's settings and, per run
key ``<Task>__<algo>__<seed>``, its run directory (relative to ``DIR``) and state: ``pending``,
``running``, ``done`` or ``failed`` (with the error), and ``placements``: where each attempt ran
(host, pid and, on Ray, the node id; ``DIR/.status/<key>.json`` holds the latest, written by the
run's process when it starts). ``--resume`` skips ``done`` runs and
continues every other one from its latest checkpoint (``relmogen train --resume`` semantics: at
most one checkpoint interval lost).

Backends: ``ray`` runs each run as a Ray task (``num_cpus`` = ``--cpus-per-run``, a fresh worker
process per task so its CPU-time budget counts that run only, retried up to ``MAX_RETRIES`` times
when its worker dies or an environment worker fails: a retry resumes the run directory) on a
local Ray started here or on a cluster (``--address``). ``serial`` runs them one after another,
each in a child process (which dies with the sweep), and never imports Ray.

Budgets: ``--episodes N`` per run, or ``--cpu-hours H`` per run (``TrainConfig.max_cpu_hours``:
CPU time of the trainer and its environment workers).

At the end (and with ``relmogen sweep --report DIR``) each finished run is evaluated as Table I
needs (``evaluate_path``: latest checkpoint, deterministic, arm collision on, ``EVAL_SEED`` and
``--eval-episodes``, default 100), one ``relmogen report`` is written per (task, algorithm) in
``DIR/<Task>__<algo>/`` and the combined Table I in ``DIR/README.md``.
"""

from __future__ import annotations

import json
import multiprocessing as mp
import os
import signal
import socket
import sys
import time
import traceback
from collections import defaultdict
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Callable

MANIFEST = "sweep.json"
RUNS = "runs"
STATUS = ".status"  # DIR/.status/<key>.json: written by a run's process when it starts (placement())
STATES = ("pending", "running", "done", "failed")
EVAL_SEED = 100_000
EVAL_EPISODES = 100
MAX_RETRIES = 2
UNBOUNDED_EPISODES = 10**9  # the episode budget of a --cpu-hours sweep
MANIFEST_VERSION = 1


@dataclass
class SweepSpec:
    """What a sweep trains; stored in the manifest, so ``--resume`` needs only ``--out``."""

    tasks: list[str]
    algos: list[str]
    seeds: list[int]
    preset: str = "cpu"
    overrides: list[str] = field(default_factory=list)
    episodes: int | None = None
    cpu_hours: float | None = None
    device: str = "auto"

    def keys(self) -> list[str]:
        return [run_key(task, algo, seed) for task in self.tasks for algo in self.algos for seed in self.seeds]

    def config(self, task: str, algo: str, seed: int):
        """The run's ``TrainConfig`` (``relmogen train``'s resolution, with the sweep's budget)."""
        from relmogen.experiments.config import resolve_config

        overrides = list(self.overrides) + ([f"max_cpu_hours={self.cpu_hours}"] if self.cpu_hours else [])
        episodes = self.episodes or (UNBOUNDED_EPISODES if self.cpu_hours else 1000)
        return resolve_config(task, algo, seed, self.preset, episodes, self.device, overrides)


def run_key(task: str, algo: str, seed: int) -> str:
    return f"{task}__{algo}__{seed}"


def split_key(key: str) -> tuple[str, str, int]:
    task, algo, seed = key.split("__")
    return task, algo, int(seed)


# ------------------------------------------------------------------------- manifest
def read_manifest(out: Path) -> dict:
    path = Path(out) / MANIFEST
    if not path.is_file():
        raise ValueError(f"{out} has no {MANIFEST}; start the sweep without --resume (or --report) first")
    return json.loads(path.read_text())


def write_manifest(out: Path, manifest: dict) -> None:
    """Atomically: a reader (or a ``kill -9``) sees the old file or the new one, never half of one."""
    path = Path(out) / MANIFEST
    tmp = path.with_name(f".{MANIFEST}.{os.getpid()}.tmp")
    tmp.write_text(json.dumps(manifest, indent=1) + "\n")
    os.replace(tmp, path)


def new_manifest(spec: SweepSpec) -> dict:
    runs = {key: {"state": "pending", "run_dir": None, "error": None} for key in spec.keys()}
    return {"version": MANIFEST_VERSION, "spec": asdict(spec), "runs": runs}


def failed_runs(manifest: dict, noun: str, retry: str) -> list[str]:
    """One error line per run of ``manifest`` that did not finish and, if any did not, one line
    that says how to continue (``retry``); empty when every run is done."""
    failed = {key: entry["error"] for key, entry in manifest["runs"].items() if entry["state"] != "done"}
    lines = [f"relmogen: error: {noun} {key} failed: {error}" for key, error in failed.items()]
    if failed:
        lines.append(f"relmogen: {len(failed)} of {len(manifest['runs'])} {noun}s failed; continue with: {retry}")
    return lines


def find_run_dir(out: Path, key: str, remove_empty: bool = False) -> Path | None:
    """The run directory of ``key`` under ``out/runs`` (the newest, should there be several). With
    ``remove_empty`` (only the process about to train that run), an empty folder left by a kill at
    its creation is removed; readers such as the live table must not, or they race ``train``
    between its mkdir and its config.yaml."""
    found = []
    for path in sorted((Path(out) / RUNS).glob(f"{key}__*")):
        if (path / "config.yaml").is_file():
            found.append(path)
        elif remove_empty and path.is_dir() and not any(path.iterdir()):
            path.rmdir()
    return found[-1] if found else None


# ------------------------------------------------------------------------ one run
def placement() -> dict:
    """Where this process runs: host, pid, start time and, in a Ray task, the Ray node id."""
    place = {"host": socket.gethostname(), "pid": os.getpid(), "time": time.time(), "node_id": None}
    ray = sys.modules.get("ray")  # not imported here: the serial backend never imports Ray
    if ray is not None and ray.is_initialized():
        place["node_id"] = ray.get_runtime_context().get_node_id()
    return place


def mark_started(out: Path, key: str) -> dict:
    """Writes ``out/.status/<key>.json`` (atomically: the driver polls it) and returns the placement."""
    place = placement()
    (out / STATUS).mkdir(exist_ok=True)
    path = out / STATUS / f"{key}.json"
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    tmp.write_text(json.dumps(place))
    os.replace(tmp, path)
    return place


def execute_run(out: str, key: str, spec: dict) -> dict:
    """Train run ``key`` of the sweep in ``out``, or continue it from its latest checkpoint when
    its directory exists (a resumed sweep, or a retried Ray task). Runs in the worker process."""
    from relmogen.experiments.resume import resume
    from relmogen.experiments.train import train

    out = Path(out)
    place = mark_started(out, key)
    run_dir = find_run_dir(out, key, remove_empty=True)
    if run_dir is None:
        run_dir = train(SweepSpec(**spec).config(*split_key(key)), out / RUNS, quiet=True)
    elif not (run_dir / "done.json").is_file():
        run_dir = resume(run_dir, quiet=True)
    return {"run_dir": str(run_dir.relative_to(out)), "placement": place}


def evaluate_run(run_dir: str, episodes: int) -> dict:
    """Table I's evaluation of a finished run (skipped when its file is already there)."""
    from relmogen.experiments.evaluate import evaluate_path

    result = evaluate_path(Path(run_dir), episodes, EVAL_SEED, arm_collision=True, quiet=True)
    return {"success_rate": result["success_rate"]}


# ------------------------------------------------------------------------- backends
class SerialBackend:
    """One job at a time, each in a fresh child process that dies with this one."""

    name = "serial"

    def __init__(self, cpus_per_run: float = 1):
        self.context = mp.get_context("spawn")

    def run(self, jobs: list[tuple[str, Callable, tuple]], on_start, on_finish, poll=lambda: None) -> None:
        for key, function, args in jobs:
            on_start(key)
            receiver, sender = self.context.Pipe(duplex=False)
            process = self.context.Process(target=_child, args=(sender, function, args), name=f"relmogen-{key}")
            process.start()
            sender.close()
            while process.is_alive() and not receiver.poll(0.5):
                poll()
            try:
                reply = receiver.recv() if receiver.poll(5) else None
            except (EOFError, OSError):  # it died without a word: SIGKILL, out of memory, ...
                reply = None
            process.join()
            receiver.close()
            if reply is None:
                from relmogen.experiments.env_workers import exit_reason

                on_finish(key, None, exit_reason(process.exitcode))
            else:
                on_finish(key, *reply)

    def close(self) -> None:
        pass


def _child(sender, function, args) -> None:
    _die_with_parent()
    try:
        result, error = function(*args), None
    except BaseException as exc:  # reported to the sweep, which goes on with the next run
        traceback.print_exc()
        result, error = None, f"{type(exc).__name__}: {exc}"
    try:
        sender.send((result, error))
    except (BrokenPipeError, OSError):
        pass


def _die_with_parent() -> None:
    """Linux: the kernel sends SIGKILL to this process when the sweep dies (``kill -9``), so a
    training run never outlives the sweep that ``--resume`` would start again."""
    try:
        import ctypes

        ctypes.CDLL("libc.so.6", use_errno=True).prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG
    except (OSError, AttributeError):
        return
    if os.getppid() == 1:  # the parent was already gone
        os._exit(1)


class RayBackend:
    """Each job a Ray task: ``num_cpus`` = cpus per run, a fresh worker per task, retried on worker death."""

    name = "ray"

    def __init__(self, cpus_per_run: float = 1, address: str | None = None, num_cpus: int | None = None):
        import ray

        self.ray, self.cpus_per_run, self.started = ray, cpus_per_run, False
        address = address or os.environ.get("RAY_ADDRESS")  # ray.init's own default, made explicit
        if not ray.is_initialized():
            if address:
                ray.init(address=address, log_to_driver=False)
            else:
                ray.init(num_cpus=num_cpus or os.cpu_count(), include_dashboard=False, log_to_driver=False)
            self.started = True

    def run(self, jobs: list[tuple[str, Callable, tuple]], on_start, on_finish, poll=lambda: None) -> None:
        from relmogen.experiments.env_workers import EnvWorkerError

        remote = {}
        for key, function, args in jobs:
            if function not in remote:
                remote[function] = self.ray.remote(num_cpus=self.cpus_per_run, max_calls=1, max_retries=MAX_RETRIES,
                                                   retry_exceptions=[EnvWorkerError])(function)
        refs = {remote[function].remote(*args): key for key, function, args in jobs}
        for key in refs.values():
            on_start(key)
        while refs:
            ready, _ = self.ray.wait(list(refs), num_returns=1, timeout=1.0)
            poll()
            for ref in ready:
                key = refs.pop(ref)
                try:
                    on_finish(key, self.ray.get(ref), None)
                except Exception as exc:  # RayTaskError (the run's exception) or a worker that died MAX_RETRIES+1 times
                    cause = getattr(exc, "cause", None) or exc
                    on_finish(key, None, f"{type(cause).__name__}: {str(cause).strip().splitlines()[-1][:300]}")

    def close(self) -> None:
        if self.started:
            self.ray.shutdown()


def make_backend(backend: str, cpus_per_run: float = 1, address: str | None = None):
    if backend == "serial":
        if address:
            raise ValueError("--address names a Ray cluster; use it with --backend ray")
        return SerialBackend(cpus_per_run)
    if backend == "ray":
        return RayBackend(cpus_per_run, address)
    raise ValueError(f"unknown backend {backend!r}; use ray or serial")


# ------------------------------------------------------------------------ progress
def run_progress(run_dir: Path | None) -> dict:
    """Episodes logged, the latest periodic evaluation's SR and the CPU hours spent, from the run's files."""
    progress = {"episodes": 0, "eval_sr": None, "cpu_hours": None}
    if run_dir is None:
        return progress
    progress["episodes"] = _last_episode(run_dir / "episodes.csv")
    periodic = run_dir / "eval_during_training.jsonl"
    lines = periodic.read_text().strip().splitlines() if periodic.is_file() else []
    if lines:
        progress["eval_sr"] = json.loads(lines[-1]).get("success_rate")
    from relmogen.experiments.checkpoints import latest_checkpoint

    checkpoint = latest_checkpoint(run_dir)
    for state_file in (run_dir / "done.json", checkpoint / "state.json" if checkpoint else None):
        if state_file is not None and state_file.is_file():
            progress["cpu_hours"] = json.loads(state_file.read_text()).get("cpu_time_s", 0.0) / 3600
            break
    return progress


def _last_episode(path: Path) -> int:
    if not path.is_file():
        return 0
    with open(path, "rb") as handle:
        handle.seek(max(0, path.stat().st_size - 4096))
        lines = handle.read().decode(errors="replace").strip().splitlines()
    for line in reversed(lines):
        first = line.split(",", 1)[0]
        if first.isdigit():
            return int(first)
    return 0


def progress_table(out: Path, manifest: dict):
    from rich.table import Table

    table = Table(title=f"sweep {out}")
    for column, justify in (("run", "left"), ("state", "left"), ("episodes", "right"), ("eval SR", "right"),
                            ("CPU h", "right")):
        table.add_column(column, justify=justify)
    for key, entry in manifest["runs"].items():
        run_dir = Path(out) / entry["run_dir"] if entry["run_dir"] else find_run_dir(out, key)
        progress = run_progress(run_dir)
        state = entry["state"] + (f" ({entry['error']})" if entry.get("error") else "")
        table.add_row(key, state, str(progress["episodes"]),
                      "-" if progress["eval_sr"] is None else f"{progress['eval_sr']:.2f}",
                      "-" if progress["cpu_hours"] is None else f"{progress['cpu_hours']:.3f}")
    return table


# ---------------------------------------------------------------------------- sweep
def run_sweep(out: Path, spec: SweepSpec | None = None, resume: bool = False, backend: str = "ray",
              address: str | None = None, cpus_per_run: float = 1, eval_episodes: int = EVAL_EPISODES,
              quiet: bool = False) -> dict:
    """Train every run of ``spec`` (or, with ``resume``, of ``out/sweep.json``), then evaluate and
    report the finished ones. Returns the manifest."""
    out = Path(out).resolve()
    manifest = _open_manifest(out, spec, resume)
    spec = SweepSpec(**manifest["spec"])
    for key in spec.keys():  # every name and value checked before anything runs
        spec.config(*split_key(key))
    from relmogen.experiments.train import check_trainable

    for task in spec.tasks:
        for algo in spec.algos:
            check_trainable(spec.config(task, algo, spec.seeds[0]))
    (out / RUNS).mkdir(parents=True, exist_ok=True)
    write_manifest(out, manifest)
    executor = make_backend(backend, cpus_per_run, address)
    try:
        todo = [key for key, entry in manifest["runs"].items() if entry["state"] != "done"]
        jobs = [(key, execute_run, (str(out), key, manifest["spec"])) for key in todo]
        with LiveTable(out, manifest, quiet):
            executor.run(jobs, *manifest_updates(out, manifest, serial=executor.name == "serial"))
        evaluate_and_report(out, manifest, executor, eval_episodes, quiet)
    finally:
        executor.close()
    return manifest


def _open_manifest(out: Path, spec: SweepSpec | None, resume: bool) -> dict:
    if resume:
        manifest = read_manifest(out)
        if spec is not None and asdict(spec) != manifest["spec"]:
            raise ValueError(f"{out}/{MANIFEST} holds another sweep ({_describe(manifest['spec'])}); resume it with "
                             f"--resume --out {out} alone, or start this one in a new --out")
        return manifest
    if spec is None:
        raise ValueError("a new sweep needs --tasks, --algos and --seeds")
    if (out / MANIFEST).is_file():
        raise ValueError(f"{out} already holds a sweep; continue it with relmogen sweep --resume --out {out}")
    return new_manifest(spec)


def _describe(spec: dict) -> str:
    return f"tasks {' '.join(spec['tasks'])}, algos {' '.join(spec['algos'])}, seeds {' '.join(map(str, spec['seeds']))}"


def manifest_updates(out: Path, manifest: dict, serial: bool):
    """(on_start, on_finish, poll) callbacks that keep ``sweep.json`` current."""
    submitted: dict[str, float] = {}

    def on_start(key: str) -> None:
        entry = manifest["runs"][key]
        entry.update(state="running" if serial else "pending", error=None)
        submitted[key] = time.time()
        write_manifest(out, manifest)

    def place(key: str, found: dict | None) -> bool:
        """Appends ``found`` (a ``placement()``) to the run's placements unless it is there already."""
        places = manifest["runs"][key].setdefault("placements", [])
        if found is None or found["time"] < submitted.get(key, 0) - 1 or found in places:
            return False
        places.append(found)
        return True

    def status_of(key: str) -> dict | None:
        try:
            return json.loads((out / STATUS / f"{key}.json").read_text())
        except (OSError, ValueError):
            return None

    def on_finish(key: str, result: dict | None, error: str | None) -> None:
        entry = manifest["runs"][key]
        place(key, status_of(key))
        if error is None:
            place(key, result.get("placement"))
            entry.update(state="done", run_dir=result["run_dir"], error=None)
        else:
            run_dir = find_run_dir(out, key)
            entry.update(state="failed", error=error, run_dir=str(run_dir.relative_to(out)) if run_dir else None)
        write_manifest(out, manifest)

    def poll() -> None:  # Ray: a task (or its retry) has started once its process wrote its status file
        changed = False
        for key in submitted:
            entry = manifest["runs"][key]
            if entry["state"] in ("pending", "running") and place(key, status_of(key)):
                entry["state"], changed = "running", True
            if entry["run_dir"] is None and entry["state"] == "running":
                run_dir = find_run_dir(out, key)
                if run_dir is not None:
                    entry["run_dir"], changed = str(run_dir.relative_to(out)), True
        if changed:
            write_manifest(out, manifest)

    return on_start, on_finish, poll


class LiveTable:
    """The live table of runs on stderr (nothing when quiet)."""

    def __init__(self, out: Path, manifest: dict, quiet: bool):
        self.live = None
        if not quiet:
            from rich.console import Console
            from rich.live import Live

            self.live = Live(console=Console(stderr=True), refresh_per_second=1,
                             get_renderable=lambda: progress_table(out, manifest))

    def __enter__(self):
        if self.live is not None:
            self.live.start()
        return self

    def __exit__(self, *exc) -> None:
        if self.live is not None:
            self.live.stop()
            if not self.live.console.is_terminal:
                self.live.console.line()


# --------------------------------------------------------------------------- report
def evaluate_and_report(out: Path, manifest: dict | None = None, executor=None,
                        eval_episodes: int = EVAL_EPISODES, quiet: bool = False) -> Path | None:
    """Evaluates every finished run (once per checkpoint and episode count), writes a report per
    (task, algorithm) in ``out/<Task>__<algo>/`` and Table I in ``out/README.md`` (returned; None
    when no run has finished)."""
    from relmogen.experiments.report import write_report
    from relmogen.experiments.table1 import write_table1

    out = Path(out).resolve()
    manifest = manifest or read_manifest(out)
    finished = {key: out / entry["run_dir"] for key, entry in manifest["runs"].items()
                if entry["state"] == "done" and entry["run_dir"]}
    jobs = [(key, evaluate_run, (str(run_dir), eval_episodes)) for key, run_dir in finished.items()
            if not _has_table1_evaluation(run_dir, eval_episodes)]
    if jobs:
        owned = executor is None
        executor = executor or SerialBackend()
        failures: dict[str, str] = {}

        def record(key: str, result: dict | None, error: str | None) -> None:
            if error is not None:
                failures[key] = error

        executor.run(jobs, lambda key: None, record)
        if owned:
            executor.close()
        for key, error in failures.items():
            finished.pop(key)
            manifest["runs"][key]["eval_error"] = error
            if not quiet:
                print(f"relmogen sweep: evaluation of {key} failed: {error}")
    groups: dict[tuple[str, str], list[Path]] = defaultdict(list)
    for key, run_dir in finished.items():
        task, algo, _ = split_key(key)
        groups[(task, algo)].append(run_dir)
    for (task, algo), run_dirs in sorted(groups.items()):
        folder = out / f"{task}__{algo}"
        write_report(run_dirs, folder)
        (folder / "COMMANDS.md").write_text(_commands(manifest["spec"], eval_episodes, run_dirs, out))
    return write_table1(out) if groups else None


def _has_table1_evaluation(run_dir: Path, episodes: int) -> bool:
    from relmogen.experiments.checkpoints import latest_checkpoint

    checkpoint = latest_checkpoint(run_dir)
    pattern = f"*collision-on_{episodes}ep_{checkpoint.name if checkpoint else 'none'}_seed{EVAL_SEED}.json"
    return any((run_dir / "eval").glob(pattern))


def _commands(spec: dict, eval_episodes: int, run_dirs: list[Path], out: Path) -> str:
    budget = f"--cpu-hours {spec['cpu_hours']}" if spec["cpu_hours"] else f"--episodes {spec['episodes'] or 1000}"
    sets = "".join(f" --set {item}" for item in spec["overrides"])
    lines = ["# Commands", "", "Made by `relmogen sweep` (settings in `../sweep.json`):", "", "```bash",
             f"relmogen sweep --tasks {' '.join(spec['tasks'])} --algos {' '.join(spec['algos'])} --seeds "
             f"{' '.join(map(str, spec['seeds']))} --preset {spec['preset']}{sets} {budget} --out {out.name} "
             f"--eval-episodes {eval_episodes}", "```", "", "Each run evaluated as:", "", "```bash"]
    lines += [f"relmogen eval {out.name}/{run_dir.relative_to(out)} --episodes {eval_episodes} --seed {EVAL_SEED} "
              f"--arm-collision on" for run_dir in sorted(run_dirs)]
    return "\n".join(lines + ["```", ""])

