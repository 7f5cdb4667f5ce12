"""relmogen reproduce --address on a two-node Ray cluster made on this machine (issue 55).

``ray.cluster_utils.Cluster`` starts a head node and a second node, 1 CPU each, as separate Ray
node processes (GCS and raylets) on this machine, sharing its file system (the "shared storage"
case of docs/sweep.md). A tiny one-stage recipe of 2 seeds is reproduced through the CLI with
``--address``: each seed is a Ray task of 1 CPU, so the two run at once, one per node. The manifest
records where each attempt of a seed ran (``placements``: host, pid, Ray node id).

Once the seed on the second node has written its first checkpoint, that node is removed: its
training process is frozen (SIGSTOP, so that the removal is surely mid-run), the node's Ray
processes are killed (``Cluster.remove_node(allow_graceful=False)``), then the frozen process
too, as when a machine is lost. Ray reports the lost task as a system failure and retries it
(``max_retries=MAX_RETRIES``); the retry runs on the head node once its CPU is free, resumes the
run folder from its checkpoint, and the report is written. The head's GCS health check is
tightened (0.5 s period, 3 misses) so the lost node is declared dead in ~1.5 s rather than ~15 s;
a tiny episode takes well under a second, hence the SIGSTOP. About 35-45 s on 2 busy cores.

Not covered: nodes on separate machines (no shared file system, token authentication between
machines); here every node sees the same ``--out``.
"""

import csv
import json
import os
import signal
import threading
import time
from pathlib import Path

import psutil
import pytest
import yaml

from relmogen.cli import main
from relmogen.experiments.recipes import BASE_DIR, content_sha256
from relmogen.experiments.sweep import STATUS, read_manifest
from relmogen.experiments.checkpoints import latest_checkpoint

# Ray tests share one xdist worker (scripts/test.sh: --dist loadgroup): two Ray starts at once clash
pytestmark = pytest.mark.xdist_group("ray")

RECIPE = {
    "title": "tiny two-node recipe", "task": "PointNav", "algo": "relmogen-r", "base": "tiny-2026-12",
    "base_sha256": content_sha256(BASE_DIR / "tiny-2026-12.yaml"), "seeds": [0, 1],
    "stages": {"train": {"budget": {"episodes": 2}}},
    "evaluation": {"episodes": 2, "seed": 100000, "checkpoint": "latest",
                   "validation": {"every_episodes": 1000, "episodes": 1, "seed": None}},
    "paper": {"metric": "success_rate", "value": 0.72},
    "ours": {"mean": 0.0, "std": 0.0, "max": 0.0, "cpu_hours_per_seed": 0.01, "episodes_per_seed": 2,
             "folder": "nowhere", "runs": {}},
}
KEYS = [f"PointNav__relmogen-r__{seed}" for seed in (0, 1)]
NODE_ARGS = {"num_cpus": 1, "object_store_memory": 80 * 2**20}


def episodes_in(run_dir: Path) -> list[int]:
    if not (run_dir / "episodes.csv").is_file():
        return []
    with open(run_dir / "episodes.csv", newline="") as handle:
        return [int(row["episode"]) for row in csv.DictReader(handle)]


@pytest.fixture
def two_nodes():
    """A head node and a second node of 1 CPU each; every Ray process is gone afterwards."""
    ray = pytest.importorskip("ray")
    from ray.cluster_utils import Cluster

    earlier = {process.pid for process in psutil.Process().children(recursive=True)}  # other tests' on this worker
    cluster = Cluster(initialize_head=True, head_node_args={
        **NODE_ARGS, "include_dashboard": False,
        # a lost node is declared dead after ~1.5 s instead of the default ~15 s
        "_system_config": {"health_check_period_ms": 500, "health_check_failure_threshold": 3}})
    try:
        worker = cluster.add_node(**NODE_ARGS)
        cluster.wait_for_nodes()
        yield cluster, worker
    finally:
        ours = [process for process in psutil.Process().children(recursive=True) if process.pid not in earlier]
        if ray.is_initialized():
            ray.shutdown()
        cluster.shutdown()
        _, alive = psutil.wait_procs(ours, timeout=60)  # 30 s was short for an orphaned ray::IDLE on a loaded machine
        for process in alive:
            process.kill()
        assert not alive, f"Ray processes outlived the cluster: {[process.pid for process in alive]}"


def remove_node_mid_run(cluster, node, out: Path, removed: dict, stop: threading.Event) -> None:
    """Once the seed placed on ``node`` has a checkpoint, freeze its process, remove the node, kill the process."""
    while not stop.is_set() and not removed:
        for key in KEYS:
            try:
                status = json.loads((out / STATUS / f"{key}.json").read_text())
            except (OSError, ValueError):
                continue
            run_dirs = sorted((out / "runs" / "train").glob(f"{key}__*"))
            if status["node_id"] == node.node_id and run_dirs and latest_checkpoint(run_dirs[-1]) is not None:
                os.kill(status["pid"], signal.SIGSTOP)
                removed.update(key=key, pid=status["pid"], episodes=len(episodes_in(run_dirs[-1])), time=time.time(),
                               states={key: entry["state"] for key, entry in read_manifest(out)["runs"].items()})
                cluster.remove_node(node, allow_graceful=False)
                try:
                    os.kill(status["pid"], signal.SIGKILL)
                except ProcessLookupError:
                    pass
                return
        time.sleep(0.05)


def test_reproduce_on_two_nodes_places_seeds_on_both_and_recovers_a_lost_node(tmp_path, two_nodes):
    cluster, worker = two_nodes
    head_id, worker_id = cluster.head_node.node_id, worker.node_id
    recipe, out = tmp_path / "tiny.yaml", tmp_path / "out"
    recipe.write_text(yaml.safe_dump(RECIPE, sort_keys=False))
    removed, stop = {}, threading.Event()
    killer = threading.Thread(target=remove_node_mid_run, args=(cluster, worker, out, removed, stop), daemon=True)
    killer.start()
    started = time.time()
    try:
        code = main(["reproduce", str(recipe), "--address", cluster.address, "--quiet", "--out", str(out)])
    finally:
        stop.set()
        killer.join(timeout=60)
    print(f"reproduce on two nodes: {time.time() - started:.1f} s; node removed "
          f"{removed.get('time', started) - started:.1f} s in")
    assert code == 0
    manifest = read_manifest(out)
    assert {key: entry["state"] for key, entry in manifest["runs"].items()} == dict.fromkeys(KEYS, "done")

    # both nodes trained a seed; the removed node's seed was running when it went (the head's seed
    # of 2 tiny episodes may already have finished by then)
    assert removed and removed["states"][removed["key"]] == "running"
    assert set(removed["states"].values()) <= {"running", "done"}
    first = {key: manifest["runs"][key]["placements"][0] for key in KEYS}
    assert {place["node_id"] for place in first.values()} == {head_id, worker_id}

    # the worker node was removed mid-run and Ray's retry finished that seed on the head node
    assert first[removed["key"]]["node_id"] == worker_id and removed["episodes"] < 2
    lost = manifest["runs"][removed["key"]]
    assert [place["node_id"] for place in lost["placements"]] == [worker_id, head_id]
    assert lost["placements"][0]["pid"] == removed["pid"] != lost["placements"][1]["pid"]
    run_dirs = list((out / "runs" / "train").glob(f"{removed['key']}__*"))
    assert run_dirs == [out / lost["run_dir"]]  # the retry resumed the run folder instead of starting another
    assert episodes_in(run_dirs[0]) == [1, 2] and (run_dirs[0] / "done.json").is_file()
    trainers = {int(path.name.split(".")[-2]) for path in (run_dirs[0] / "tb").glob("events.out.tfevents.*")}
    assert trainers == {place["pid"] for place in lost["placements"]}  # both attempts trained in that folder
    other = manifest["runs"][next(key for key in KEYS if key != removed["key"])]
    assert [place["node_id"] for place in other["placements"]] == [head_id]

    # evaluated (on the remaining node) and reported
    for entry in manifest["runs"].values():
        assert entry["evaluations"] == [0]
        (evaluation,) = (out / entry["run_dir"] / "eval").glob("*.json")
        assert json.loads(evaluation.read_text())["episodes"] == 2
    assert manifest["report"] == str(out / "README.md") and (out / "README.md").is_file()
    assert {path.name for path in (out / "PointNav__relmogen-r").iterdir()} >= {"table.md", "table.json",
                                                                                 "curves.png", "COMMANDS.md"}
