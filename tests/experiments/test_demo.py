"""``relmogen demo``: the shipped PushDoorNav policy runs without training and writes a GIF."""

import json

import imageio.v2 as imageio
import pytest

import relmogen.experiments.rollout as rollout
import relmogen.experiments.video as video
from relmogen.cli import main
from relmogen.experiments.shipped import POLICIES_DIR, shipped_policy_dir
from relmogen.experiments.demo import DEMO_POLICY


@pytest.fixture
def fewer_frames(monkeypatch):
    """Fewer third-person frames while a subgoal executes (rendering them is most of a demo's
    time); an episode still gives a frame after the reset and one after each step."""
    monkeypatch.setattr(rollout, "FRAME_PERIOD_S", 4 * rollout.FRAME_PERIOD_S)
    monkeypatch.setattr(video, "FRAMES_PER_SUBGOAL", 1)


def test_demo_loads_the_shipped_policy_and_prints_one_json_object(tmp_path, fewer_frames, capfd):
    capfd.readouterr()  # in this process: ``relmogen --version`` covers a fresh process's output
    assert main(["demo", "--episodes", "1", "--json", "--out", str(tmp_path)]) == 0
    out = capfd.readouterr().out
    metrics = json.loads(out.strip().splitlines()[-1])
    assert metrics["task"] == "PushDoorNav" and metrics["policy"] == DEMO_POLICY
    assert metrics["episodes"] == 1 and 0.0 <= metrics["success_rate"] <= 1.0
    assert 1 <= metrics["mean_steps"] <= 25 and "subgoal_success_rate" in metrics
    frames = imageio.mimread(metrics["gif"])
    assert len(frames) > 2


def test_shipped_policy_is_small_and_unknown_names_list_the_known_ones():
    folder = shipped_policy_dir(DEMO_POLICY)
    assert sum(f.stat().st_size for f in folder.iterdir()) < 5_000_000
    try:
        shipped_policy_dir("NoSuchPolicy")
    except ValueError as error:
        assert DEMO_POLICY in str(error) and str(POLICIES_DIR) in str(error)
    else:
        raise AssertionError("an unknown policy name must be refused")


def test_demo_video_records_the_first_episode_annotated_as_mp4(tmp_path, fewer_frames):
    from relmogen.experiments.demo import run_demo
    from relmogen.experiments.video import VIDEO_SIZE

    metrics = run_demo(episodes=1, out_dir=tmp_path / "plain", quiet=True, video=tmp_path / "demo.mp4")
    assert metrics["video"] == str(tmp_path / "demo.mp4") and "gif" not in metrics
    assert not (tmp_path / "plain").exists()  # the annotated video instead of the plain GIF
    frames = imageio.mimread(metrics["video"], format="FFMPEG")
    assert len(frames) > 2 and frames[0].shape == (VIDEO_SIZE[1], VIDEO_SIZE[0], 3)
