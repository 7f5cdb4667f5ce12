"""relmogen reproduce: a tiny three-stage recipe trained, evaluated and reported on the serial backend."""

import csv
import json
import subprocess
import sys
from pathlib import Path

import yaml

from relmogen.cli import main
from relmogen.experiments.recipes import BASE_DIR, content_sha256
from relmogen.experiments.sweep import read_manifest

TINY_RECIPE = {
    "title": "tiny smoke recipe", "task": "PointNav", "algo": "relmogen-r", "base": "tiny-2026-12",
    "base_sha256": content_sha256(BASE_DIR / "tiny-2026-12.yaml"), "seeds": [0],
    "stages": {
        "first": {"budget": {"episodes": 2}},
        "second": {"init_from": "first", "init_replay": True, "budget": {"episodes": 2},
                   "set": {"algo.learning_starts": 0}, "why": {"algo.learning_starts": "the replay is loaded"}},
        "third": {"continue": "second", "budget": {"episodes": 3}},
    },
    "evaluation": {"episodes": 1, "seed": 100000, "checkpoint": "latest",
                   "validation": {"every_episodes": 1000, "episodes": 1, "seed": None},
                   "also": [{"stochastic": True}]},
    "paper": {"metric": "success_rate", "value": 0.72},
    "ours": {"mean": 0.0, "std": 0.0, "max": 0.0, "cpu_hours_per_seed": 0.01, "episodes_per_seed": 5,
             "folder": "nowhere", "runs": {}},
}
NO_RAY = ("import sys; from relmogen.cli import main; code = main(sys.argv[1:]); "
          "assert 'ray' not in sys.modules, 'the serial backend imported ray'; sys.exit(code)")


def episodes_in(run_dir: Path) -> list[int]:
    with open(run_dir / "episodes.csv", newline="") as handle:
        return [int(row["episode"]) for row in csv.DictReader(handle)]


def test_a_staged_recipe_trains_each_stage_then_evaluates_and_reports_without_ray(tmp_path):
    recipe = tmp_path / "tiny.yaml"
    recipe.write_text(yaml.safe_dump(TINY_RECIPE, sort_keys=False))
    out = tmp_path / "out"
    done = subprocess.run([sys.executable, "-c", NO_RAY, "reproduce", str(recipe), "--backend", "serial", "--quiet",
                           "--out", str(out)], capture_output=True, text=True, timeout=900)
    assert done.returncode == 0, done.stderr[-3000:]
    assert done.stdout.strip().splitlines()[-1] == str(out / "README.md")
    entry = read_manifest(out)["runs"]["PointNav__relmogen-r__0"]
    assert entry["state"] == "done" and entry["evaluations"] == [0, 1]
    first, second = out / entry["stages"]["first"], out / entry["stages"]["second"]
    assert entry["stages"]["third"] == entry["stages"]["second"] == entry["run_dir"]  # continued in place
    assert episodes_in(first) == [1, 2] and episodes_in(second) == [1, 2, 3]
    assert json.loads((second / "init_from.json").read_text())["replay"] is not None
    assert [row["from_episode"] for row in map(json.loads, (second / "resumes.jsonl").read_text().splitlines())] == [2]
    assert len(list((second / "eval").glob("*.json"))) == 2  # greedy and stochastic
    assert {path.name for path in (out / "PointNav__relmogen-r").iterdir()} >= {"table.md", "table.json",
                                                                                 "curves.png", "COMMANDS.md"}
    # resumed: nothing left to train or evaluate
    finished = (second / "episodes.csv").stat().st_mtime_ns
    assert main(["reproduce", str(recipe), "--resume", "--backend", "serial", "--quiet", "--out", str(out)]) == 0
    assert (second / "episodes.csv").stat().st_mtime_ns == finished
    assert main(["reproduce", str(recipe), "--backend", "serial", "--quiet", "--out", str(out)]) == 2  # no overwrite
    # published: the first copy makes the cell, the next goes to its reruns/ beside it
    table1 = tmp_path / "table1"
    for _ in range(2):
        assert main(["reproduce", str(recipe), "--resume", "--backend", "serial", "--quiet", "--out", str(out),
                     "--publish", str(table1)]) == 0
    cell = table1 / "PointNav__relmogen-r"
    reruns = list((cell / "reruns").iterdir())
    assert (cell / "table.json").is_file() and len(reruns) == 1
    published_runs = list((reruns[0] / "runs").rglob("config.yaml"))
    assert len(published_runs) == 2  # the first stage's run and the second's (continued by the third)
    assert not list(reruns[0].rglob("model.zip")) and not list(reruns[0].rglob("events.out.tfevents*"))
    host = json.loads((reruns[0] / "rerun.json").read_text())["host"]
    readme = (table1 / "README.md").read_text()
    assert "## Reruns from the recipes" in readme and f"| PointNav__relmogen-r | SR |" in readme
    assert f"| {host['cpu_model']} ({host['host_kind']}) |" in readme  # the host kind decides the CPU hours
