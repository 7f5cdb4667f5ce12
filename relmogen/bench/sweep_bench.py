"""``relmogen bench sweep``: what running runs as Ray tasks costs and gains on this machine.

The same small run (``--preset``, default ``tiny``; PointNav ``relmogen-r``; ``--episodes`` each,
periodic evaluations off) is trained three times through ``relmogen.experiments.sweep``'s own
code path (``execute_run``, the function a sweep runs per run):

- ``alone``: one run in a child process with nothing else of ours running (the serial backend);
- ``ray``: two runs at once as Ray tasks of 1 CPU each on a local Ray started here
  (``ray.init(num_cpus=2)``).

Reported: training throughput in episodes per wall-clock hour of each (``ray``: both runs'
episodes over the time until both finished, so on 2 idle cores it approaches twice ``alone``),
the ratio, Ray's start-up time (``ray.init``), and the resident memory (RSS, psutil) of the Ray
system processes (GCS, raylet, ...; not the workers that train), idle after start-up and at most
while the runs trained, with the RSS of the Ray workers at most. Machine load (``os.getloadavg``)
is recorded: on a busy machine the figures say little.
"""

from __future__ import annotations

import os
import tempfile
import time
from dataclasses import asdict
from pathlib import Path

import psutil

from relmogen.experiments.sweep import RayBackend, SerialBackend, SweepSpec, execute_run, run_key

ALGO = "relmogen-r"
MB = 1024 * 1024


def bench_sweep(task: str = "PointNav", preset: str = "tiny", episodes: int = 10) -> dict:
    import ray

    if ray.is_initialized():
        raise ValueError("bench sweep times Ray's start-up: run it in a process without Ray")
    spec = SweepSpec(tasks=[task], algos=[ALGO], seeds=[0, 1, 2], preset=preset, episodes=episodes,
                     overrides=["run.eval_every_episodes=1000000"])
    load_before = os.getloadavg()
    with tempfile.TemporaryDirectory(prefix="relmogen-bench-sweep-") as folder:
        out = Path(folder)
        alone_s = _timed_runs(SerialBackend(), out, spec, [0])
        ours = {process.pid for process in psutil.Process().children(recursive=True)}  # e.g. resource tracker
        started = time.perf_counter()
        ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False)
        startup_s = time.perf_counter() - started
        try:
            time.sleep(2.0)  # let the system processes settle before their idle memory is read
            idle = _ray_memory(ours)
            peak = dict(idle)

            def sample() -> None:
                for key, value in _ray_memory(ours).items():
                    peak[key] = max(peak[key], value)

            ray_s = _timed_runs(RayBackend(cpus_per_run=1), out, spec, [1, 2], poll=sample)
        finally:
            ray.shutdown()
    alone_rate, ray_rate = episodes / alone_s * 3600, 2 * episodes / ray_s * 3600
    return {"task": task, "algo": ALGO, "preset": preset, "episodes_per_run": episodes, "cpus": os.cpu_count(),
            "load_average_1m_before": round(load_before[0], 2), "load_average_1m_after": round(os.getloadavg()[0], 2),
            "alone_wall_s": round(alone_s, 2), "alone_episodes_per_hour": round(alone_rate, 1),
            "ray_2x1cpu_wall_s": round(ray_s, 2), "ray_2x1cpu_episodes_per_hour": round(ray_rate, 1),
            "ray_vs_alone": round(ray_rate / alone_rate, 3), "ray_startup_s": round(startup_s, 2),
            "ray_system_rss_mb_idle": round(idle["system"] / MB, 1),
            "ray_system_rss_mb_peak": round(peak["system"] / MB, 1),
            "ray_workers_rss_mb_peak": round(peak["workers"] / MB, 1)}


def _timed_runs(backend, out: Path, spec: SweepSpec, seeds: list[int], poll=lambda: None) -> float:
    """Wall-clock seconds until every run of ``seeds`` finished; a failed run is an error."""
    errors: dict[str, str] = {}

    def record(key: str, result: dict | None, error: str | None) -> None:
        if error is not None:
            errors[key] = error

    jobs = [(run_key(spec.tasks[0], ALGO, seed), execute_run, (str(out), run_key(spec.tasks[0], ALGO, seed),
                                                                asdict(spec))) for seed in seeds]
    started = time.perf_counter()
    backend.run(jobs, lambda key: None, record, poll)
    elapsed = time.perf_counter() - started
    if errors:
        raise RuntimeError(f"benchmark runs failed: {errors}")
    return elapsed


def _ray_memory(skip: set[int]) -> dict[str, int]:
    """RSS bytes of this process's descendants (but ``skip`` and theirs): Ray's system processes,
    and its workers with their children."""
    totals = {"system": 0, "workers": 0}

    def visit(process: psutil.Process, kind: str) -> None:
        try:
            if kind == "system" and _is_ray_worker(process):
                kind = "workers"
            totals[kind] += process.memory_info().rss
            children = process.children()
        except psutil.Error:
            return
        for child in children:
            visit(child, kind)

    for child in psutil.Process().children():
        if child.pid not in skip:
            visit(child, "system")
    return totals


def _is_ray_worker(process: psutil.Process) -> bool:
    """Ray names its worker processes ``ray::IDLE``, ``ray::execute_run``, ..."""
    try:
        cmdline = process.cmdline()
    except psutil.Error:
        return False
    return bool(cmdline) and cmdline[0].startswith("ray::") or "default_worker.py" in " ".join(cmdline)
