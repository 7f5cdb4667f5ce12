"""relmogen sweep: tiny sweeps on both backends, the manifest, and resume after kill -9."""

import csv
import json
import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import psutil
import pytest

from relmogen.cli import main
from relmogen.experiments.sweep import MANIFEST, STATUS, SweepSpec, find_run_dir, read_manifest, run_sweep
from relmogen.experiments.checkpoints import latest_checkpoint

# Ray tests share one xdist worker (scripts/test.sh: --dist loadgroup): two Ray starts at once clash.
# Only the tests that start Ray: the serial ones run beside them on the other worker.
ray_group = pytest.mark.xdist_group("ray")

TASKS = ["PointNav", "TabletopReachM"]
SWEEP = ["sweep", "--tasks", *TASKS, "--algos", "relmogen-r", "--seeds", "0", "1", "--preset", "tiny",
         "--episodes", "2", "--eval-episodes", "2", "--quiet"]


@pytest.fixture(scope="module")
def ray_session():
    """One local Ray for the module (the sweep uses it and leaves it running)."""
    ray = pytest.importorskip("ray")
    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False)
    yield ray
    ray.shutdown()


def episodes_in(run_dir: Path) -> list[int]:
    with open(run_dir / "episodes.csv", newline="") as handle:
        return [int(row["episode"]) for row in csv.DictReader(handle)]


def assert_finished_sweep(out: Path, tasks=TASKS) -> None:
    manifest = read_manifest(out)
    assert {entry["state"] for entry in manifest["runs"].values()} == {"done"}
    assert sorted(manifest["runs"]) == sorted(f"{task}__relmogen-r__{seed}" for task in tasks for seed in (0, 1))
    for entry in manifest["runs"].values():
        run_dir = out / entry["run_dir"]
        assert episodes_in(run_dir) == [1, 2] and (run_dir / "done.json").is_file()
        (evaluation,) = (run_dir / "eval").glob("*collision-on_2ep_*_seed100000.json")
        assert json.loads(evaluation.read_text())["episodes"] == 2
    readme = (out / "README.md").read_text()
    for task in tasks:
        assert (out / f"{task}__relmogen-r" / "table.json").is_file()
        line = next(line for line in readme.splitlines() if line.startswith(f"| {task} |"))  # the main table's
        assert "(2)" in line.split("|")[3]  # relmogen-r ours: mean / std / max over 2 seeds


def test_a_serial_sweep_trains_evaluates_and_writes_table_1_without_ray(tmp_path):
    code = ("import sys; from relmogen.cli import main; code = main(sys.argv[1:]); "
            "assert 'ray' not in sys.modules, 'the serial backend imported ray'; sys.exit(code)")
    out = tmp_path / "sweep"
    done = subprocess.run([sys.executable, "-c", code, *SWEEP, "--backend", "serial", "--out", str(out)],
                          capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr[-2000:]
    assert done.stdout.strip().splitlines()[-1] == str(out / "README.md")
    assert_finished_sweep(out)
    assert main(["sweep", "--report", str(out), "--backend", "serial", "--eval-episodes", "2", "--quiet"]) == 0
    assert len(list((out / "runs").glob("*/eval/*.json"))) == 4  # the evaluations were there: not run again


@ray_group
def test_a_ray_sweep_runs_each_run_as_a_ray_task(tmp_path, ray_session):
    out = tmp_path / "sweep"  # one task: the serial sweep above covers Table I over several tasks
    sweep = [arg for arg in SWEEP if arg != "TabletopReachM"]
    assert main([*sweep, "--backend", "ray", "--out", str(out)]) == 0
    assert_finished_sweep(out, tasks=["PointNav"])
    status = [json.loads(path.read_text()) for path in (out / ".status").glob("*.json")]
    assert len(status) == 2 and os.getpid() not in {entry["pid"] for entry in status}  # Ray workers trained them
    assert ray_session.is_initialized()  # a Ray the sweep did not start is left running


@ray_group
def test_a_ray_task_whose_worker_is_killed_is_retried_and_resumes_its_run_directory(tmp_path, ray_session):
    out, key = tmp_path / "sweep", "PointNav__relmogen-r__0"
    spec = SweepSpec(tasks=["PointNav"], algos=["relmogen-r"], seeds=[0], preset="tiny", episodes=5,
                     overrides=["run.eval_every_episodes=1000"])
    killed = {}

    def kill_the_worker_after_two_episodes() -> None:
        deadline = time.time() + 240
        while time.time() < deadline and not killed:
            run_dir, status = find_run_dir(out, key), out / STATUS / f"{key}.json"
            if run_dir and status.is_file() and (run_dir / "episodes.csv").is_file() and len(episodes_in(run_dir)) >= 2:
                killed["pid"] = json.loads(status.read_text())["pid"]
                os.kill(killed["pid"], signal.SIGKILL)
            time.sleep(0.05)

    killer = threading.Thread(target=kill_the_worker_after_two_episodes)
    killer.start()
    try:
        manifest = run_sweep(out, spec, backend="ray", eval_episodes=1, quiet=True)
    finally:
        killer.join()
    assert killed and manifest["runs"][key]["state"] == "done"
    assert json.loads((out / STATUS / f"{key}.json").read_text())["pid"] != killed["pid"]  # a second attempt
    (run_dir,) = (out / "runs").iterdir()  # which resumed the run directory instead of starting another
    assert episodes_in(run_dir) == [1, 2, 3, 4, 5]


def test_a_sweep_refuses_another_sweep_in_its_folder_and_bad_names(tmp_path):
    spec = SweepSpec(tasks=["PointNav"], algos=["relmogen-r"], seeds=[0], preset="tiny", episodes=1)
    (tmp_path / MANIFEST).write_text(json.dumps({"version": 1, "spec": {**spec.__dict__, "seeds": [5]}, "runs": {}}))
    with pytest.raises(ValueError, match="already holds a sweep"):
        run_sweep(tmp_path, spec, backend="serial", quiet=True)
    with pytest.raises(ValueError, match="holds another sweep"):
        run_sweep(tmp_path, spec, resume=True, backend="serial", quiet=True)
    assert main(["sweep", "--tasks", "PointNov", "--algos", "relmogen-r", "--seeds", "0", "--out",
                 str(tmp_path / "new"), "--backend", "serial"]) == 2
    assert not (tmp_path / "new" / MANIFEST).exists()  # nothing written for a bad name
    assert main(["sweep", "--report", str(tmp_path), "--out", str(tmp_path)]) == 2


def test_resume_after_kill_9_of_the_sweep_skips_finished_runs_and_loses_at_most_one_checkpoint(tmp_path):
    out = tmp_path / "sweep"
    cmd = [sys.executable, "-m", "relmogen.cli", "sweep", "--tasks", "PointNav", "--algos", "relmogen-r", "--seeds",
           "0", "1", "--preset", "tiny", "--episodes", "5", "--eval-episodes", "1", "--backend", "serial",
           "--quiet", "--out", str(out), "--set", "run.eval_every_episodes=1000"]
    sweep = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        deadline = time.time() + 300
        while time.time() < deadline:
            runs = read_manifest(out)["runs"] if (out / MANIFEST).is_file() else {}
            second = runs.get("PointNav__relmogen-r__1", {})
            if (runs.get("PointNav__relmogen-r__0", {}).get("state") == "done" and second.get("run_dir")
                    and (out / second["run_dir"] / "episodes.csv").is_file()
                    and len(episodes_in(out / second["run_dir"])) >= 2):
                break
            time.sleep(0.05)
        else:
            raise AssertionError("the sweep never got into its second run")
        children = psutil.Process(sweep.pid).children()
        os.kill(sweep.pid, signal.SIGKILL)
        sweep.wait()
    finally:
        if sweep.poll() is None:
            sweep.kill()
            sweep.wait()
    _, alive = psutil.wait_procs(children, timeout=30)
    assert not alive  # the training child died with the sweep
    manifest = read_manifest(out)
    first, second = (out / manifest["runs"][f"PointNav__relmogen-r__{seed}"]["run_dir"] for seed in (0, 1))
    assert manifest["runs"]["PointNav__relmogen-r__1"]["state"] == "running"
    saved = json.loads((latest_checkpoint(second) / "state.json").read_text())["episodes"]
    assert len(episodes_in(second)) - saved <= 1  # tiny: a checkpoint every episode
    finished = (first / "episodes.csv").stat().st_mtime_ns
    assert main(["sweep", "--resume", "--out", str(out), "--backend", "serial", "--eval-episodes", "1",
                 "--quiet"]) == 0
    assert (first / "episodes.csv").stat().st_mtime_ns == finished  # the finished run was skipped
    assert episodes_in(second) == [1, 2, 3, 4, 5]
    resumes = json.loads((latest_checkpoint(second) / "state.json").read_text())
    assert resumes["episodes"] == 5 and read_manifest(out)["runs"]["PointNav__relmogen-r__1"]["state"] == "done"
    assert (out / "README.md").is_file()
