"""``relmogen oracle``: the scripted policies, through either subgoal control."""

import pytest

from relmogen.experiments.oracle import run_oracle


def test_an_oracle_acts_through_the_discrete_control_as_its_nearest_actions():
    result = run_oracle("PointNav", episodes=1, control="subgoal-d", image_size=64, quiet=True)
    assert result["control"] == "subgoal-d" and result["image_size"] == 64 and result["push_frame"] == "base"
    assert result["episodes"] == 1 and result["base_fraction"] == 1.0 and result["base_plan_rate"] > 0.5
    assert result["goal_distance"] < 1.0  # the nearest cells and yaw bins still lead it to the goal


def test_random_discrete_actions_and_joint_control_are_refused():
    with pytest.raises(ValueError, match="relmogen analyse random-sgpd"):
        run_oracle("PointNav", episodes=1, policy="random", control="subgoal-d", image_size=64, quiet=True)
    with pytest.raises(ValueError, match="got control 'joint'"):
        run_oracle("PointNav", episodes=1, control="joint", image_size=64, quiet=True)


def test_oracle_video_records_one_annotated_episode(tmp_path):
    import imageio.v2 as imageio

    from relmogen.experiments.oracle import run_oracle

    result = run_oracle("PointNav", 1, video=tmp_path / "pointnav.gif", image_size=64, quiet=True)
    frames = imageio.mimread(result["video"])
    assert len(frames) > 1 and frames[0].shape[:2] == (384, 512)
