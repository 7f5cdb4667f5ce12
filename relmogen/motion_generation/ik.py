"""Position-only inverse kinematics of the end-effector link over the planning chain.

PyBullet's damped-least-squares IK (``p.calculateInverseKinematics``) works on every movable
joint (wheels, head and fingers too) and returns one value per movable joint; only the torso and
the 7 arm joints are read back, the others are frozen at their current values through their
limits. Two PyBullet quirks shape the code:

* ``currentPositions`` ignores the pose of a floating base (errors of tens of centimetres once
  the robot is away from the origin), so the seed is set on the body itself and the robot's
  planning joints are restored afterwards;
* the returned angles can leave the joint limits: full-turn roll joints are wrapped, the rest
  clipped, and every accepted solution is verified by forward kinematics.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import pybullet as p

from relmogen.robots.robot import Robot

Config = np.ndarray
_FULL_TURN = 2.0 * np.pi - 1e-6
# An attempt still this far from the target after the first PROBE_ITERATIONS is abandoned; the others
# go on from there to the full count. On TabletopReachM table points, random seeds reached the 5 cm
# tolerance as often after 20 iterations as after 100 (0.42 of attempts), and 1 success in 174 was
# further than 0.3 m at 20; a random attempt cost 0.27 ms of CPU at 20 iterations, 0.80 at 100.
PROBE_ITERATIONS, ABANDON_DISTANCE_M = 20, 0.3


@dataclass(frozen=True)
class IKResult:
    config: Config | None  # torso + 7 arm joints, or None
    reason: str
    error_m: float  # forward-kinematics distance to the target of the best candidate
    attempts: int


def wrap_angle(a: np.ndarray) -> np.ndarray:
    return (np.asarray(a) + np.pi) % (2.0 * np.pi) - np.pi


class ArmIK:
    """IK for ``robot.arm_joint_indices``; the base, head and fingers never move."""

    def __init__(self, client: int, robot: Robot):
        self.client, self.robot = client, robot
        body = robot.robot_id
        self.movable_joints = np.array([j for j in range(p.getNumJoints(body, physicsClientId=client))
                                        if p.getJointInfo(body, j, physicsClientId=client)[2] != p.JOINT_FIXED])
        self.arm_joints = robot.arm_joint_indices
        self._arm_slots = np.searchsorted(self.movable_joints, self.arm_joints)
        if not np.array_equal(self.movable_joints[self._arm_slots], self.arm_joints):
            raise ValueError("planning joints must be movable joints")
        self.lower, self.upper = robot.joint_lower[self.arm_joints], robot.joint_upper[self.arm_joints]
        self._full_turn = (self.upper - self.lower) >= _FULL_TURN

    # ------------------------------------------------------------------ state helpers

    def planning_state(self) -> tuple[Config, Config]:
        return self.robot.joint_state_vector()

    def restore(self, state: tuple[Config, Config]) -> None:
        for j, q, v in zip(self.arm_joints, *state):
            p.resetJointState(self.robot.robot_id, int(j), float(q), float(v), physicsClientId=self.client)

    def end_effector_at(self, q: Config) -> np.ndarray:
        """Forward kinematics: sets the planning joints (no restore) and reads the link frame."""
        self.robot.set_joint_positions(self.arm_joints, q)
        return self.robot.end_effector_position()

    def random_config(self, rng: np.random.Generator) -> Config:
        return rng.uniform(self.lower, self.upper)

    # ------------------------------------------------------------------ single IK calls

    def _limits(self, rest: Config) -> tuple[list, list, list, list]:
        """Limit/rest vectors over all movable joints; non-planning joints pinned where they are."""
        current = self.robot.get_joint_positions(self.movable_joints)
        lower, upper, rest_all = current.copy(), current.copy(), current.copy()
        lower[self._arm_slots], upper[self._arm_slots], rest_all[self._arm_slots] = self.lower, self.upper, rest
        return lower.tolist(), upper.tolist(), (upper - lower).tolist(), rest_all.tolist()

    def _raw_ik(self, target: np.ndarray, seed: Config, rest: Config, iterations: int) -> Config:
        self.robot.set_joint_positions(self.arm_joints, seed)
        lower, upper, ranges, rest_all = self._limits(rest)
        solution = p.calculateInverseKinematics(
            self.robot.robot_id, self.robot.end_effector_link_index, list(map(float, target)),
            lowerLimits=lower, upperLimits=upper, jointRanges=ranges, restPoses=rest_all,
            maxNumIterations=iterations, residualThreshold=1e-4, physicsClientId=self.client)
        return np.asarray(solution, dtype=np.float64)[self._arm_slots]

    def _into_limits(self, q: Config, near: Config | None = None) -> Config:
        """Wrap full-turn joints (to ``[-pi, pi)`` or, with ``near``, to the closest turn) and clip."""
        q = q.copy()
        turn = self._full_turn
        q[turn] = wrap_angle(q[turn]) if near is None else near[turn] + wrap_angle(q[turn] - near[turn])
        return np.clip(q, self.lower, self.upper)

    # ------------------------------------------------------------------ solvers

    def solve(self, target: np.ndarray, rng: np.random.Generator, iterations: int, attempts: int,
              tolerance: float, is_valid: Callable[[Config], bool] | None = None,
              from_current: bool = True) -> IKResult:
        """First attempt seeded from the current pose (unless ``from_current`` is false), then
        random seeds and rest poses.

        A candidate is accepted when its forward-kinematics error is at most ``tolerance`` and
        ``is_valid(q)`` (e.g. collision-free) holds. The planning joints are restored.
        """
        target = np.asarray(target, dtype=np.float64)
        saved = self.planning_state()
        best_error, reachable = np.inf, False
        try:
            for attempt in range(attempts):
                current = attempt == 0 and from_current
                seed = saved[0] if current else self.random_config(rng)
                rest = saved[0] if current else self.random_config(rng)
                q, probe_error = self._probed_ik(target, seed, rest, iterations)
                if q is None:
                    best_error = min(best_error, probe_error)
                    continue
                q = self._into_limits(q)
                error = float(np.linalg.norm(self.end_effector_at(q) - target))
                best_error = min(best_error, error)
                if error > tolerance:
                    continue
                reachable = True
                if is_valid is None or is_valid(q):
                    return IKResult(q, "solved", error, attempt + 1)
        finally:
            self.restore(saved)
        reason = "IK solution in collision" if reachable else f"no IK solution within {tolerance:g} m"
        return IKResult(None, reason, best_error, attempts)

    def _probed_ik(self, target: np.ndarray, seed: Config, rest: Config,
                   iterations: int) -> tuple[Config | None, float]:
        """``_raw_ik`` with ``iterations`` (the solver goes on from where ``PROBE_ITERATIONS``
        stopped), or None when the probe is still more than ``ABANDON_DISTANCE_M`` away; and the
        probe's distance to the target (0 without a probe)."""
        if iterations <= PROBE_ITERATIONS:
            return self._raw_ik(target, seed, rest, iterations), 0.0
        probe = self._raw_ik(target, seed, rest, PROBE_ITERATIONS)
        distance = float(np.linalg.norm(self.end_effector_at(probe) - target))
        if distance > ABANDON_DISTANCE_M:
            return None, distance
        return self._raw_ik(target, probe, rest, iterations - PROBE_ITERATIONS), distance

    def track_line(self, points: np.ndarray, start: Config, iterations: int) -> np.ndarray:
        """Joint targets following ``points`` in order, each IK seeded from the previous one
        (no tolerance: a blocked push still gets targets). Returns ``(len(points), 8)``."""
        saved = self.planning_state()
        targets, q = [], np.asarray(start, dtype=np.float64)
        try:
            for point in points:
                q = self._into_limits(self._raw_ik(point, q, q, iterations), near=q)
                targets.append(q)
        finally:
            self.restore(saved)
        return np.array(targets).reshape(len(points), len(self.arm_joints))
