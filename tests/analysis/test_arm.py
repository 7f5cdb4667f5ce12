"""``relmogen analyse arm-settings`` / ``door-front`` / ``ik-contacts``: the arm under other settings."""

import numpy as np
import pytest

from relmogen.agents.oracles.base import arm_action_at_pixel, world_to_pixel
from relmogen.analysis.arm import (IKCollisionRecorder, contacts_at_ik_solution, door_front_plan_rates,
                                   oracle_figures, parse_setting, random_step_costs, set_arm_settings)
from relmogen.envs.relmogen_env import RelmogenEnv


@pytest.fixture(scope="module")
def door_env():
    env = RelmogenEnv(task="PushDoorNav", control="subgoal-r", image_size=64)
    yield env
    env.close()


def test_settings_are_parsed_and_checked_against_arm_config():
    assert parse_setting("now") == ("now", {})
    assert parse_setting("x=push_sub_steps:2,target_penetration_allowance:0.05,arm_reach:10") == (
        "x", {"push_sub_steps": 2, "target_penetration_allowance": 0.05, "arm_reach": 10})
    assert parse_setting("off=collision_checking:false")[1] == {"collision_checking": False}
    with pytest.raises(ValueError, match="unknown arm setting ik_restart"):
        parse_setting("bad=ik_restart:3")


def test_a_setting_rebuilds_the_motion_generator_from_the_original_configuration(door_env):
    original = door_env.control.mg
    settings = set_arm_settings(door_env, {"push_sub_steps": 2, "plan_attempts": 1, "arm_reach": 5.0,
                                           "collision_checking": False})
    mg = door_env.control.mg
    assert mg is not original and mg.arm.config.push_sub_steps == 2 and mg.arm.config.plan_attempts == 1
    assert not mg.config.arm_collision_checking and not mg.arm.config.collision_checking
    assert door_env.robot.spec.arm_reach == 5.0
    settings.apply({"ik_restarts": 7})  # from the original, not on top of the last one
    assert door_env.control.mg.arm.config.plan_attempts == original.arm.config.plan_attempts
    assert door_env.control.mg.arm.config.ik_restarts == 7 and door_env.control.mg.config.arm_collision_checking
    assert door_env.robot.spec.arm_reach == 1.2
    settings.apply({})


def test_random_steps_replay_the_same_actions_under_each_setting():
    rows = random_step_costs("PushDoorNav", {"defaults": {}, "two": {"push_sub_steps": 2}}, episodes=1,
                             episode_steps=8, seed=1)
    assert [r["setting"] for r in rows] == ["defaults", "two"] and all(r["steps"] == 8 for r in rows)
    assert rows[0]["arm_steps"] == rows[1]["arm_steps"] > 0 and rows[0]["arm_beyond_reach"] == rows[1]["arm_beyond_reach"]
    assert all(r["step_ms"] > 0 and r["step_cpu_ms"] >= 0 for r in rows)


def test_oracle_figures_under_a_setting():
    result = oracle_figures("TabletopReachM", {"push_points": 10}, episodes=1, image_size=64)
    assert result["episodes"] == 1 and result["overrides"] == {"push_points": 10}
    assert result["success_rate"] == 1.0 and result["arm_plan_rate"] == 1.0 and result["cpu_s"] > 0


def test_without_checking_every_door_front_subgoal_plans():
    off, strict = door_front_plan_rates({"off": {"collision_checking": False},
                                         "strict": {"target_penetration_allowance": 0.03}}, trials=4)
    assert off["trials"] == strict["trials"] == 4
    assert off["planned"] == 4 and off["failures"] == {}
    assert strict["planned"] <= off["planned"] and strict["planned"] + sum(strict["failures"].values()) == 4


def test_a_base_parked_at_the_door_puts_the_gripper_into_it(door_env):
    door_env.reset(seed=3)
    door, normal = door_env.task.door, np.asarray(door_env.task.doorway.normal)
    bar = door.face_point(0.45, door.bar_height)
    base = bar[:2] - 0.31 * normal  # the bumper 3 cm from the door
    door_env.robot.set_base_pose(base[0], base[1], float(np.arctan2(*(bar[:2] - base)[::-1])))
    assert door_env.control.mg.arm.solve_ik(bar, np.random.default_rng(0)).reason == "IK solution in collision"
    hits = contacts_at_ik_solution(door_env, bar, np.random.default_rng(0))
    assert ("gripper_link", "door") in hits and all(body != "floor" for _, body in hits)
    # the recorder reads the same from an arm subgoal that failed so (the step left the world as it was)
    obs, _, _, _, _ = door_env.step(np.array([1, 0, -1, 0, 0, 0, 0, 0], np.float32))  # a base subgoal in place
    action = arm_action_at_pixel(door_env, *world_to_pixel(door_env, bar), np.zeros(3))
    recorder = IKCollisionRecorder()
    recorder.start(door_env, obs)
    recorder.before_step(obs, action)
    recorder.after_step(obs, 0.0, {"subgoal_type": "arm", "reason": "IK solution in collision"})
    recorder.after_step(obs, 0.0, {"subgoal_type": "arm", "reason": "pushed 0.2 of 0.25 m"})  # not counted
    (case,) = recorder.cases
    assert case["target_body"] == "door" and ("gripper_link", "door") in case["contacts"]
    assert 0.2 < case["distance"] < 0.7
