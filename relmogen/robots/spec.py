"""Embodiment specs: everything robot-specific, loaded from ``assets/<name>/spec.yaml``.

Adding a robot means adding a folder with a URDF and a ``spec.yaml``; no Python changes. Its
measured arm reachability map (``reachability.npz``, for ``env.reach_mask=measured``) is written
there by ``python -m relmogen.motion_generation.reachability <name>``.
"""

from __future__ import annotations

from dataclasses import dataclass, fields
from pathlib import Path
from typing import Any

import yaml

ASSETS_DIR = Path(__file__).resolve().parent / "assets"
SPEC_FILE = "spec.yaml"


class SpecError(ValueError):
    """A spec.yaml is missing a field or has a field of the wrong shape."""


@dataclass(frozen=True)
class LidarSpec:
    num_rays: int
    fov_deg: float
    max_range: float
    min_range: float


@dataclass(frozen=True)
class WheelJoints:
    left: str
    right: str


@dataclass(frozen=True)
class HeadJoints:
    pan: str
    tilt: str


@dataclass(frozen=True)
class EmbodimentSpec:
    """Names and numbers the rest of the code needs about one robot."""

    name: str
    urdf: str  # relative to the spec file
    spec_dir: Path
    wheel_joints: WheelJoints
    wheel_radius: float
    wheel_separation: float
    torso_joint: str
    arm_joints: tuple[str, ...]
    head_joints: HeadJoints
    gripper_joints: tuple[str, ...]
    gripper_open: tuple[float, ...]
    end_effector_link: str
    gripper_links: tuple[str, ...]
    camera_link: str
    lidar_link: str
    wheel_links: tuple[str, ...]
    caster_links: tuple[str, ...]
    wheel_friction: float
    base_radius: float
    arm_reach: float  # metres from the first arm joint's link beyond which no arm subgoal is planned
    default_torso: float
    default_arm_pose: tuple[float, ...]
    head_tilt_navigation: float
    head_tilt_tabletop: float
    velocity_limits: tuple[float, ...]  # left wheel, right wheel, torso, arm joints
    lidar: LidarSpec

    @property
    def urdf_path(self) -> Path:
        return (self.spec_dir / self.urdf).resolve()

    @property
    def planning_joints(self) -> tuple[str, ...]:
        """Torso followed by the arm joints: the joint-space planning chain."""
        return (self.torso_joint, *self.arm_joints)

    @property
    def controlled_joints(self) -> tuple[str, ...]:
        """Joints driven by a normalised velocity action, in action order."""
        return (self.wheel_joints.left, self.wheel_joints.right, *self.planning_joints)


def available_robots() -> list[str]:
    return sorted(d.name for d in ASSETS_DIR.iterdir() if (d / SPEC_FILE).is_file())


def load_spec(name: str) -> EmbodimentSpec:
    """Load ``assets/<name>/spec.yaml``; unknown names raise ``ValueError`` listing valid ones."""
    robots = available_robots()
    if name not in robots:
        raise ValueError(f"unknown robot {name!r}; available robots: {', '.join(robots)}")
    return load_spec_file(ASSETS_DIR / name / SPEC_FILE)


def load_spec_file(path: str | Path) -> EmbodimentSpec:
    path = Path(path).resolve()
    with path.open() as f:
        raw = yaml.safe_load(f)
    if not isinstance(raw, dict):
        raise SpecError(f"{path}: expected a mapping at the top level")
    try:
        spec = _build_spec(dict(raw), path.parent)
    except SpecError as e:
        raise SpecError(f"{path}: {e}") from None
    if not spec.urdf_path.is_file():
        raise SpecError(f"{path}: urdf file not found: {spec.urdf_path}")
    return spec


# ---------------------------------------------------------------- field parsing helpers

def _build_spec(raw: dict[str, Any], spec_dir: Path) -> EmbodimentSpec:
    expected = {f.name for f in fields(EmbodimentSpec)} - {"spec_dir"}
    missing, unknown = expected - raw.keys(), raw.keys() - expected
    if missing or unknown:
        raise SpecError(f"missing fields {sorted(missing)}, unknown fields {sorted(unknown)}")
    arm = _names(raw, "arm_joints")
    spec = EmbodimentSpec(
        name=_str(raw, "name"),
        urdf=_str(raw, "urdf"),
        spec_dir=spec_dir,
        wheel_joints=WheelJoints(**_str_map(raw, "wheel_joints", ("left", "right"))),
        wheel_radius=_positive(raw, "wheel_radius"),
        wheel_separation=_positive(raw, "wheel_separation"),
        torso_joint=_str(raw, "torso_joint"),
        arm_joints=arm,
        head_joints=HeadJoints(**_str_map(raw, "head_joints", ("pan", "tilt"))),
        gripper_joints=_names(raw, "gripper_joints"),
        gripper_open=_floats(raw, "gripper_open"),
        end_effector_link=_str(raw, "end_effector_link"),
        gripper_links=_names(raw, "gripper_links"),
        camera_link=_str(raw, "camera_link"),
        lidar_link=_str(raw, "lidar_link"),
        wheel_links=_names(raw, "wheel_links"),
        caster_links=_names(raw, "caster_links"),
        wheel_friction=_positive(raw, "wheel_friction"),
        base_radius=_positive(raw, "base_radius"),
        arm_reach=_positive(raw, "arm_reach"),
        default_torso=_float(raw, "default_torso"),
        default_arm_pose=_floats(raw, "default_arm_pose", len(arm)),
        head_tilt_navigation=_float(raw, "head_tilt_navigation"),
        head_tilt_tabletop=_float(raw, "head_tilt_tabletop"),
        velocity_limits=_floats(raw, "velocity_limits", 3 + len(arm)),
        lidar=_lidar(raw),
    )
    if len(spec.gripper_open) != len(spec.gripper_joints):
        raise SpecError("gripper_open needs one value per gripper joint")
    if min(spec.velocity_limits) <= 0:
        raise SpecError("velocity_limits must all be positive")
    return spec


def _str(raw: dict, key: str) -> str:
    value = raw[key]
    if not isinstance(value, str) or not value:
        raise SpecError(f"field {key!r} must be a non-empty string, got {value!r}")
    return value


def _float(raw: dict, key: str) -> float:
    value = raw[key]
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise SpecError(f"field {key!r} must be a number, got {value!r}")
    return float(value)


def _positive(raw: dict, key: str) -> float:
    value = _float(raw, key)
    if value <= 0:
        raise SpecError(f"field {key!r} must be positive, got {value}")
    return value


def _sequence(raw: dict, key: str, length: int | None) -> list:
    value = raw[key]
    if not isinstance(value, list):
        raise SpecError(f"field {key!r} must be a list, got {value!r}")
    if length is not None and len(value) != length:
        raise SpecError(f"field {key!r} must have {length} entries, got {len(value)}")
    return value


def _names(raw: dict, key: str, length: int | None = None) -> tuple[str, ...]:
    items = _sequence(raw, key, length)
    return tuple(_str({key: item}, key) for item in items)


def _floats(raw: dict, key: str, length: int | None = None) -> tuple[float, ...]:
    items = _sequence(raw, key, length)
    return tuple(_float({key: item}, key) for item in items)


def _str_map(raw: dict, key: str, keys: tuple[str, ...]) -> dict[str, str]:
    value = raw[key]
    if not isinstance(value, dict) or set(value) != set(keys):
        raise SpecError(f"field {key!r} must be a mapping with keys {list(keys)}, got {value!r}")
    return {k: _str(value, k) for k in keys}


def _lidar(raw: dict) -> LidarSpec:
    value = raw["lidar"]
    keys = [f.name for f in fields(LidarSpec)]
    if not isinstance(value, dict) or set(value) != set(keys):
        raise SpecError(f"field 'lidar' must be a mapping with keys {keys}, got {value!r}")
    num_rays = value["num_rays"]
    if isinstance(num_rays, bool) or not isinstance(num_rays, int) or num_rays < 2:
        raise SpecError(f"lidar.num_rays must be an integer >= 2, got {num_rays!r}")
    return LidarSpec(num_rays, *(_positive(value, k) for k in keys[1:]))
