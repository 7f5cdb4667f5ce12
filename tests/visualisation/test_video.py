"""Annotated episode videos: what the policy chose is drawn where it is, and both formats are written."""

import imageio.v3 as iio
import numpy as np
import pytest

from relmogen.envs.relmogen_env import RelmogenEnv
from relmogen.experiments.rollout import run_episode
from relmogen.experiments.video import (ARM_COLOUR, GOAL_COLOUR, INSET_SIZE, MARGIN, VIDEO_SIZE,
                                          AnnotatedRecorder, chosen_subgoal)
from relmogen.simulation.views import check_animation_path, overhead_camera, write_animation


def has_colour(image: np.ndarray, colour) -> bool:
    return bool(np.all(image == np.asarray(colour[:3], np.uint8), axis=-1).any())


def test_a_base_subgoal_is_drawn_at_its_goal_in_the_overhead_view():
    env = RelmogenEnv(task="PointNav", control="subgoal-d", image_size=32, episode_steps=2)
    try:
        obs, _ = env.reset(seed=0)
        action = env.control.encode("base", 3, env.control.q // 2, env.control.q - 1)  # 0.3 m ahead, 2.2 m left
        subgoal = chosen_subgoal(env, action)
        pose = env.robot.base_pose()
        offset = subgoal.base_goal[:2] - np.array(pose[:2])
        left = np.array([-np.sin(pose[2]), np.cos(pose[2])])
        assert subgoal.part == "base" and offset @ left == pytest.approx(2.1875, abs=1e-6)
        recorder = AnnotatedRecorder()
        run_episode(env, lambda _: action, seed=0, recorder=recorder)
    finally:
        env.close()
    assert all(frame.shape == (VIDEO_SIZE[1], VIDEO_SIZE[0], 3) for frame in recorder.frames)
    assert len(recorder.frames) >= 3 and has_colour(recorder.frames[-1], GOAL_COLOUR)


def test_an_arm_subgoal_is_drawn_on_the_camera_inset_with_its_push():
    env = RelmogenEnv(task="TabletopReachM", control="subgoal-r", image_size=32, episode_steps=1)
    try:
        env.reset(seed=0)
        action = np.array([-1, 0, 0, 0, 0.3, 0.0, 0.5, 0.0], np.float32)  # the floor in front, pushed forward
        subgoal = chosen_subgoal(env, action)
        assert subgoal.part == "arm" and subgoal.arm_point is not None and subgoal.push_end is not None
        recorder = AnnotatedRecorder()
        run_episode(env, lambda _: action, seed=0, recorder=recorder)
    finally:
        env.close()
    inset = recorder.frames[-1][MARGIN:MARGIN + INSET_SIZE, -MARGIN - INSET_SIZE:-MARGIN]
    assert has_colour(inset, ARM_COLOUR)


def test_the_overhead_camera_looks_down_at_the_robot():
    camera = overhead_camera((2.0, 1.0, 0.7), 512, 384)
    (x, y), = camera.project(np.array([2.0, 1.0, 0.0]))
    assert abs(x - 256) < 1 and abs(y - 192) < 1
    (x, y), = camera.project(np.array([2.0 + np.cos(0.7), 1.0 + np.sin(0.7), 0.0]))  # a metre ahead: up
    assert abs(x - 256) < 1 and y < 192 - 20


def test_videos_are_written_as_gif_or_mp4_by_suffix(tmp_path):
    frames = [np.full((64, 96, 3), value, np.uint8) for value in (0, 128, 255)]
    for name in ("clip.gif", "clip.mp4"):
        path = write_animation(frames, tmp_path / name, fps=5)
        assert iio.improps(path, index=None).shape[1:3] == (64, 96)
    with pytest.raises(ValueError, match=".gif or .mp4"):
        check_animation_path(tmp_path / "clip.avi")
