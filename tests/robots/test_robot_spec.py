"""EmbodimentSpec loading and validation."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from relmogen.robots.spec import EmbodimentSpec, SpecError, available_robots, load_spec, load_spec_file


def test_fetch_is_available_and_loads(fetch_spec):
    assert "fetch" in available_robots()
    assert isinstance(fetch_spec, EmbodimentSpec)
    assert fetch_spec.urdf_path.is_file() and fetch_spec.urdf_path.is_absolute()
    assert len(fetch_spec.arm_joints) == 7 and len(fetch_spec.default_arm_pose) == 7
    assert len(fetch_spec.velocity_limits) == 10
    assert fetch_spec.planning_joints[0] == fetch_spec.torso_joint
    assert fetch_spec.lidar.num_rays == 220 and fetch_spec.lidar.max_range == 25.0


def test_spec_is_frozen(fetch_spec):
    with pytest.raises(AttributeError):
        fetch_spec.base_radius = 1.0


def test_unknown_robot_lists_valid_names():
    with pytest.raises(ValueError, match="fetch"):
        load_spec("no_such_robot")


def _write_variant(tmp_path: Path, fetch_spec, **changes) -> Path:
    raw = yaml.safe_load((fetch_spec.spec_dir / "spec.yaml").read_text())
    raw.update(changes)
    raw["urdf"] = str(fetch_spec.urdf_path)
    path = tmp_path / "spec.yaml"
    path.write_text(yaml.safe_dump(raw))
    return path


@pytest.mark.parametrize("changes, message", [
    ({"arm_joints": "shoulder_pan_joint"}, "arm_joints"),
    ({"velocity_limits": [1.0, 1.0]}, "velocity_limits"),
    ({"wheel_radius": -0.1}, "wheel_radius"),
    ({"head_joints": {"pan": "head_pan_joint"}}, "head_joints"),
    ({"lidar": {"num_rays": 2.5, "fov_deg": 220, "max_range": 25, "min_range": 0.05}}, "num_rays"),
    ({"typo_field": 1}, "typo_field"),
])
def test_malformed_fields_raise_clear_errors(tmp_path, fetch_spec, changes, message):
    with pytest.raises(SpecError, match=message):
        load_spec_file(_write_variant(tmp_path, fetch_spec, **changes))


def test_valid_copy_loads(tmp_path, fetch_spec):
    spec = load_spec_file(_write_variant(tmp_path, fetch_spec))
    assert spec.arm_joints == fetch_spec.arm_joints
