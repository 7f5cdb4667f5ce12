"""Where can SGP-D's arm actions succeed? Two measurements behind the arm mask (``arm_reach``).

``reach``: over 8 episodes (seeds 1000+), after two random free-cell base subgoals, 25 random
arm actions (state restored before each): does the arm planner find a plan, against the
distance from the first arm joint to the point the pixel sees? Prints counts per distance
band and writes every sample as JSON.

``button`` (ButtonDoorNav): with the robot standing 0.65 m in front of the button facing
it, which of the 12 push directions of the 3 x 3 cells around the button's pixel press it?

    python results/sgpd-reach/diagnose_sgpd_arm.py reach --task ButtonDoorNav --out results/sgpd-reach
    python results/sgpd-reach/diagnose_sgpd_arm.py button --out results/sgpd-reach
"""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path

import numpy as np

from relmogen.agents.oracles.base import world_to_pixel
from relmogen.envs.relmogen_env import RelmogenEnv
from relmogen.envs.subgoal_controls import PUSH_BINS, Q_DOWNSAMPLE, YAW_BINS

BANDS = ((0.0, 0.6), (0.6, 0.8), (0.8, 1.0), (1.0, 1.2), (1.2, 1.5), (1.5, math.inf))


def make_env(task: str) -> RelmogenEnv:
    return RelmogenEnv(task=task, control="subgoal-d", image_size=64, arm_collision=False)


def reach_samples(task: str, episodes: int = 8, per_state: int = 25) -> list[dict]:
    env, rng, samples = make_env(task), np.random.default_rng(0), []
    control = env.control
    for episode in range(episodes):
        env.reset(seed=1000 + episode)
        for _ in range(2):
            free = np.argwhere(control.extra_info()["base_mask"])
            if len(free):
                i, j = free[rng.integers(len(free))]
                env.step(control.encode("base", int(rng.integers(YAW_BINS)), int(i), int(j)))
        state = env.world.save_state()
        for _ in range(per_state):
            env.world.restore_state(state)
            env._observe()
            k, i, j = rng.integers(PUSH_BINS), rng.integers(control.q), rng.integers(control.q)
            row, col = Q_DOWNSAMPLE * i + Q_DOWNSAMPLE // 2, Q_DOWNSAMPLE * j + Q_DOWNSAMPLE // 2
            sample = {"depth": float(env.last_frame.depth[row, col])}
            if sample["depth"] > 0:
                point = env.camera.pixel_to_world(env.last_frame, col, row)
                sample.update(height=float(point[2]),
                              distance=float(np.linalg.norm(point - env.robot.arm_base_position())))
            info = env.step(control.encode("arm", int(k), int(i), int(j)))[-1]
            samples.append(dict(sample, plan_found=bool(info["plan_found"]), reason=info["reason"]))
    env.close()
    return samples


def reach_summary(samples: list[dict]) -> dict:
    bands = {}
    for low, high in BANDS:
        band = [s for s in samples if s["depth"] > 0 and low <= s["distance"] < high]
        bands[f"{low}-{high}"] = {"arm_actions": len(band), "planned": sum(s["plan_found"] for s in band)}
    return {"arm_actions": len(samples), "planned": sum(s["plan_found"] for s in samples),
            "no_depth": sum(s["depth"] <= 0 for s in samples), "by_distance_m": bands}


def button_presses(episodes: int = 4, stand_off: float = 0.65) -> list[dict]:
    env, rows = make_env("ButtonDoorNav"), []
    control = env.control
    for episode in range(episodes):
        env.reset(seed=episode)
        button = env.task.button
        xy = button.face_xy + stand_off * button.out_normal
        env.robot.set_base_pose(xy[0], xy[1], math.atan2(-button.out_normal[1], -button.out_normal[0]))
        env._observe()
        pixel = world_to_pixel(env, button.face_centre())
        if pixel is None:
            continue
        state = env.world.save_state()
        centre = (pixel[0] // Q_DOWNSAMPLE, pixel[1] // Q_DOWNSAMPLE)
        for di in (-1, 0, 1):
            for dj in (-1, 0, 1):
                cell = (centre[0] + di, centre[1] + dj)
                pressed = []
                for k in range(PUSH_BINS):
                    env.world.restore_state(state)
                    env.task.mechanism.pressed = False
                    env._observe()
                    env.step(control.encode("arm", k, *cell))
                    pressed.append(bool(env.task.mechanism.pressed))
                rows.append({"episode": episode, "cell": cell, "button_cell": cell == centre,
                             "directions_pressing": [k for k in range(PUSH_BINS) if pressed[k]]})
    env.close()
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("what", choices=("reach", "button"))
    parser.add_argument("--task", default="ButtonDoorNav")
    parser.add_argument("--out", type=Path, required=True)
    args = parser.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    if args.what == "reach":
        samples = reach_samples(args.task)
        summary = {"task": args.task, **reach_summary(samples)}
        (args.out / f"reach_{args.task}.json").write_text(json.dumps({**summary, "samples": samples}, indent=1))
    else:
        rows = button_presses()
        pressing = sum(len(r["directions_pressing"]) for r in rows)
        summary = {"states": len({r["episode"] for r in rows}), "actions_tried": len(rows) * PUSH_BINS,
                   "actions_pressing": pressing}
        (args.out / "button_presses.json").write_text(json.dumps({**summary, "cells": rows}, indent=1))
    print(json.dumps(summary))


if __name__ == "__main__":
    main()
