"""Tiny runs of ``relmogen bench planner`` and ``relmogen bench env``: every key present,
numbers finite, rates in [0, 1]. Figures that can be undefined in a tiny run (no successful
plan) are null; everything else must be a finite number."""

from __future__ import annotations

import json
import math

import pytest

from relmogen.bench.planner_bench import BACKEND_NAMES
from relmogen.bench.planner_problems import ARM_CATEGORIES, BASE_CATEGORIES
from relmogen.cli import main

BACKEND_KEYS = {"attempts", "success_rate", "median_ms", "p95_ms", "mean_path_length", "success_by_category"}
NULLABLE_BACKEND_KEYS = {"success_rate", "median_ms", "p95_ms", "mean_path_length"}
ENV_KEYS = {"task", "image_size", "samples", "joint_step_ms", "floor_ms", "ratio", "reset_ms", "reset_ms_by_task",
            "subgoal_samples",
            "subgoal_base_step_ms", "subgoal_base_step_all_ms", "subgoal_base_plan_rate", "base_step_vs_floor",
            "subgoal_arm_step_ms", "subgoal_arm_step_all_ms", "subgoal_arm_plan_rate", "arm_step_vs_floor"}
ENV_NULLABLE = {"subgoal_base_step_ms", "base_step_vs_floor", "subgoal_arm_step_ms", "arm_step_vs_floor"}


def run_json(capsys, *argv: str) -> dict:
    assert main(list(argv)) == 0
    return json.loads(capsys.readouterr().out)


def numbers(tree):
    """Every int/float leaf of a JSON tree."""
    if isinstance(tree, dict):
        for value in tree.values():
            yield from numbers(value)
    elif isinstance(tree, list):
        for value in tree:
            yield from numbers(value)
    elif isinstance(tree, (int, float)) and not isinstance(tree, bool):
        yield tree


def assert_rate(value) -> None:
    assert value is None or 0.0 <= value <= 1.0


@pytest.fixture(scope="module")
def planner_result():
    from relmogen.bench.planner_bench import bench_planner

    return bench_planner(problems=1, seed=0)


def test_planner_json_has_every_key_and_finite_numbers(planner_result):
    result = planner_result
    assert {"seed", "problems_per_category", "backends", "base", "arm", "results", "wall_time_s",
            "rrt_connect_vs_ompl_rrtconnect", "rrt_connect_vs_ompl_rrtconnect_arm"} <= set(result)
    assert result["backends"] == list(BACKEND_NAMES)
    assert set(result["results"]) == set(BACKEND_NAMES)
    assert result["base"]["problems"] == len(BASE_CATEGORIES)
    assert set(result["arm"]["by_category"]) == set(ARM_CATEGORIES)
    assert set(result["rrt_connect_vs_ompl_rrtconnect"]) == {"success_delta", "median_ratio"}
    assert all(math.isfinite(x) for x in numbers(result))


def test_planner_rates_and_per_backend_figures(planner_result):
    for name, kinds in planner_result["results"].items():
        for kind, categories in (("base", BASE_CATEGORIES), ("arm", ARM_CATEGORIES)):
            stats = kinds[kind]
            assert set(stats) == BACKEND_KEYS, (name, kind)
            assert set(stats["success_by_category"]) == set(categories)
            assert_rate(stats["success_rate"])
            for rate in stats["success_by_category"].values():
                assert_rate(rate)
            assert all(stats[k] is not None for k in BACKEND_KEYS - NULLABLE_BACKEND_KEYS)
    delta = planner_result["rrt_connect_vs_ompl_rrtconnect"]["success_delta"]
    assert delta is None or -1.0 <= delta <= 1.0
    # Rotations are feasible by construction: every backend returns them at once.
    assert planner_result["base"]["feasible_by_category"]["rotation"] == 1


def test_env_bench_json_has_subgoal_figures(capsys):
    result = run_json(capsys, "bench", "env", "--json", "--samples", "3", "--subgoal-samples", "2")
    assert ENV_KEYS <= set(result)
    for key in ENV_KEYS - {"task", "reset_ms_by_task"}:
        if key in ENV_NULLABLE and result[key] is None:
            continue
        assert math.isfinite(result[key]) and result[key] >= 0, key
    assert len(result["reset_ms_by_task"]) == 7
    assert all(math.isfinite(v) and v > 0 for v in result["reset_ms_by_task"].values())
    assert_rate(result["subgoal_base_plan_rate"])
    assert_rate(result["subgoal_arm_plan_rate"])
    assert set(result["arm_by_backend"]) == {"pybullet", "coal"}  # the same subgoals with each collision backend
    default = result["arm_by_backend"][result["arm_collision_backend"]]
    assert default["subgoal_arm_step_all_ms"] == result["subgoal_arm_step_all_ms"]
    host = result["host"]  # every bench JSON names its host
    assert host["host_kind"] in ("avx512-amx", "avx512", "avx2", "other") and host["torch_threads"] >= 1
    assert set(host["isa"]) == {"avx2", "avx512f", "avx512_bf16", "amx_tile", "amx_bf16"}


def test_planner_cli_rejects_zero_problems(capsys):
    with pytest.raises(SystemExit):
        main(["bench", "planner", "--problems", "0"])


def test_train_bench_times_updates_and_env_steps():
    from relmogen.bench.train_bench import bench_one

    result = bench_one("PointNav", "relmogen-r", "tiny", updates=2)
    for key in ("env_steps_per_s", "updates_per_s", "stock_sb3_sac_updates_per_s", "shared_encoder_speedup"):
        assert math.isfinite(result[key]) and result[key] > 0, key
    assert result["image_size"] == 64 and result["batch_size"] == 8


def test_train_bench_reports_sgpd_replay_memory():
    from relmogen.bench.train_bench import bench_one

    result = bench_one("PointNav", "relmogen-d", "tiny", updates=2)
    assert result["updates_per_s"] > 0 and result["env_steps_per_s"] > 0
    # tiny preset: 64 px, buffer of 200 transitions; per 1e4 it is the same figure scaled up
    per_1e4, at_size = result["replay_gib_per_1e4_transitions"], result["replay_gib_at_preset_size"]
    assert per_1e4 == pytest.approx(at_size * 1e4 / 200, rel=0.02) and 0.1 < per_1e4 < 1.0


def test_the_training_run_bench_counts_cpu_and_time_shares_from_the_first_update(tmp_path):
    from relmogen.bench.train_bench import bench_training_run

    result = bench_training_run("PointNav", preset="tiny", subgoals=30, out=str(tmp_path))
    assert result["subgoals_timed"] >= 10 and result["episodes_timed"] >= 1
    assert result["cpu_s"] > 0 and result["wall_s"] > 0
    assert result["episodes_per_cpu_hour"] == pytest.approx(result["episodes_timed"] / result["cpu_s"] * 3600, rel=1e-3)
    assert result["subgoals_per_cpu_s"] == pytest.approx(result["subgoals_timed"] / result["cpu_s"], rel=1e-3)
    shares = result["time_shares"]
    assert {"update", "environment", "checkpoint"} <= set(shares) and 0 < sum(shares.values()) <= 1.0
    assert list(tmp_path.iterdir()) == []  # the run folder is temporary


def test_the_training_run_bench_runs_relmogen_d_at_its_qmap_size(tmp_path):
    from relmogen.bench.train_bench import bench_training_run

    result = bench_training_run("PointNav", preset="tiny", subgoals=20, out=str(tmp_path), algo="relmogen-d")
    assert result["algo"] == "relmogen-d" and result["qmap_size"] == 16  # tiny: 64 px, the default Q = S / 4
    assert result["subgoals_timed"] >= 10 and result["episodes_per_cpu_hour"] > 0


def test_qmap_resolution_rows_compare_update_costs_against_the_first(monkeypatch):
    from relmogen.bench import train_bench

    monkeypatch.setattr(train_bench, "QMAP_SETTINGS", ((64, 16), (64, 32)))
    rows = train_bench.bench_qmap_resolutions("PointNav", updates=1, preset="tiny")
    assert [(row["image_size"], row["qmap_size"]) for row in rows] == [(64, 16), (64, 32)]
    assert rows[0]["update_cost_vs_64px_q16"] == 1.0
    assert rows[1]["update_cost_vs_64px_q16"] == pytest.approx(rows[1]["update_cpu_s"] / rows[0]["update_cpu_s"],
                                                               rel=0.01, abs=1e-3)


def test_qmap_precision_rows_compare_bfloat16_against_float32():
    from relmogen.bench import train_bench

    rows = train_bench.bench_qmap_precisions("PointNav", updates=1, preset="tiny")
    assert [row["qmap_bf16"] for row in rows] == [False, True]
    assert rows[0]["update_cost_vs_float32"] == 1.0
    assert rows[1]["update_cost_vs_float32"] == pytest.approx(rows[1]["update_cpu_s"] / rows[0]["update_cpu_s"],
                                                             rel=0.01, abs=1e-3)


def test_qmap_variant_rows_alternate_layouts_and_compare_against_the_plain_layout(monkeypatch):
    from relmogen.bench import train_bench

    monkeypatch.setattr(train_bench, "QMAP_VARIANTS", {name: train_bench.QMAP_VARIANTS[name]
                                                       for name in ("plain_layout", "lite")})
    rows = train_bench.bench_qmap_variants("PointNav", updates=1, rounds=1, preset="tiny")
    by_name = {row["variant"]: row for row in rows}
    assert list(by_name) == ["plain_layout", "lite"]
    assert by_name["plain_layout"]["speedup_vs_plain_layout"] == 1.0
    assert by_name["lite"]["speedup_vs_plain_layout"] == pytest.approx(
        by_name["plain_layout"]["update_cpu_s"] / by_name["lite"]["update_cpu_s"], rel=0.01, abs=1e-3)
    assert by_name["plain_layout"]["parameters"] != by_name["lite"]["parameters"]
    assert by_name["lite"]["overrides"] == list(train_bench.QMAP_LITE)


def test_the_plain_layout_keeps_the_q_values_of_the_channels_last_network():
    import torch as th

    from relmogen.bench.train_bench import _model_with_replay, use_plain_layout

    _, env, model, _ = _model_with_replay("PointNav", "relmogen-d", "tiny")
    obs = model.replay_buffer.sample(2).observations
    net = model.q_net.net
    with th.no_grad():
        channels_last = net(obs)
        use_plain_layout(net)
        plain = net(obs)
    env.close()
    assert all(p.is_contiguous() for p in net.parameters())
    assert th.allclose(channels_last, plain, atol=1e-5)


