"""The arm half of the motion generator: IK to a subgoal point, joint-space plan, then a push.

``ArmMotion.reach_and_push`` (paper section 4 / relmogen-facts section 4):

1. position-only IK of the gripper link on the subgoal point (PyBullet DLS, random restarts,
   accepted within ``ik_tolerance`` and, when collision checking is on, collision-free; the
   gripper may sink into the body the point lies on, ``target_penetration_allowance``);
2. joint-space plan of torso + 7 arm joints from the current (tucked) pose with the selected
   backend (``make_planner``), executed kinematically as in the original; the gripper is then
   drawn back to contact with that body, so that physics does not fling it;
3. a straight Cartesian push from the reached point along the push vector (clipped to
   ``push_max_length``), IK at ``push_points`` points, executed with physics under position
   control with the joints' URDF efforts (times ``push_force_scale``) while the base is pinned;
4. a short kinematic retreat back along the push line, then the default (tucked) pose.
"""

from __future__ import annotations

import itertools
import time
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Callable
from dataclasses import dataclass, field

import numpy as np
import pybullet as p

from relmogen.motion_generation.ik import ArmIK, Config
from relmogen.motion_generation.planners import Planner, PlanningProblem, make_planner
from relmogen.motion_generation.push import (
    PhysicsCallback,
    base_held_still,
    follow_joint_targets,
    make_push_line,
    physics_sub_steps,
    step_physics,
)
from relmogen.robots.robot import BASE_LINK, Robot
from relmogen.simulation.bodies import movable_joints
from relmogen.simulation.self_collision import SelfCollisionCopy
from relmogen.simulation.sensors import Camera, CameraFrame


@dataclass(frozen=True)
class ArmConfig:
    planner: str = "rrt_connect"
    ik_iterations: int = 100
    ik_restarts: int = 50  # IK attempts: the first from the current pose, the others random
    # When the joint-space planner finds no path to an IK solution, try another IK solution
    # (a random seed): with the paper's 20-iteration RRT-Connect, reaching over a table edge
    # fails for some solutions and not for others. 1 = the original behaviour.
    plan_attempts: int = 3
    # The arm's RRT-Connect budget (the other backends keep their own). The paper's 20 iterations x
    # 2 restarts is its base planner's; the shipped PushDoorNav policy with checking on spent 1.4
    # subgoals per episode on "no arm plan" with it, 0.3 with 100 x 4 (results/pushdoornav-mg/).
    rrt_iterations: int = 20
    rrt_restarts: int = 2
    ik_tolerance: float = 0.05  # metres, forward-kinematics check
    joint_resolution: float = 0.05  # rad (m for the torso): planner step
    collision_checking: bool = True  # the paper trains without it and evaluates with it
    # who answers collision queries inside IK solves and plans (COLLISION_BACKENDS): coal, ~5x cheaper
    # checks and ~1.5x cheaper arm subgoals, every oracle figure within noise (docs/benchmarks.md)
    collision_backend: str = "coal"
    # The gripper touches the subgoal surface by design, so its links may penetrate other
    # bodies by this much; every other arm link must stay clear.
    gripper_penetration_allowance: float = 0.03
    # ... and, from the second plan attempt on, the body the subgoal point lies on (the one to
    # push) by this much. The original never checked the gripper against the world (its IK
    # checked the 8 arm-joint links only), which let it reach through walls; here only the pushed
    # body is exempt, and only this deep. Random PushDoorNav door-front arm subgoals planned in
    # one IK + plan attempt: 35% at 0.03, 69% at 0.05, 66% at 0.08, 72% at 0.10, 99% with no
    # checking (results/pushdoornav-collision-on/arm_check_diagnosis.txt). The first attempt
    # keeps 0.03, so that what planned before plans alike.
    target_penetration_allowance: float = 0.08
    push_max_length: float = 0.25
    # 25 points x 4 physics steps: the same 2.5 s push as 50 x 2 with half the IK; every oracle
    # figure stays within noise (results/oracles/ik_tradeoff.md)
    push_points: int = 25
    push_ik_iterations: int = 10  # per push point, seeded from the previous point
    push_steps_per_point: int = 4  # physics steps per push point (25 points -> 2.5 s)
    push_settle_steps: int = 4  # hold the last target before measuring the pushed distance
    # Physics sub-steps during the push (None: the world's 2, which keep joint-velocity driving
    # straight; the base is pinned here). 1 halves the push's physics: random PushDoorNav
    # subgoals 20.7 -> 17.3 ms of CPU, every oracle figure within noise (results/oracles/push_physics.md)
    push_sub_steps: int | None = 1
    push_force_scale: float = 1.0  # multiple of each joint's URDF effort
    push_position_gain: float = 0.3
    base_hold_force: float = 1e5  # N, the constraint pinning the base during the push
    retreat_distance: float = 0.05  # m back along the push line before tucking the arm
    retreat_points: int = 5


@dataclass(frozen=True)
class ArmResult:
    success: bool
    reason: str
    planning_time_s: float = 0.0  # IK + motion planning (wall clock)
    simulated_time_s: float = 0.0  # physics steps x time step (the push)
    physics_steps: int = 0
    pushed_distance_m: float = 0.0  # gripper displacement along the push direction
    wall_time_s: float = 0.0
    goal_config: Config | None = None
    path: list[Config] | None = field(default=None, repr=False)


# pybullet: PyBullet queries; coal: inside IK solves and plans (other_joints_held), Pinocchio + Coal
# in C++ (relmogen.motion_generation.coal_collision), PyBullet elsewhere
COLLISION_BACKENDS = ("pybullet", "coal")


class ArmCollisionChecker:
    """``q (8,) -> bool``: joint limits, links moved by the planning joints against other
    bodies, and arm links against non-adjacent robot links (pairs precomputed once, checked on a
    ``SelfCollisionCopy`` of the robot: one broadphase there instead of a box per link here).

    ``target_body`` (set by ``ArmMotion`` for one subgoal): the gripper links may penetrate that
    body by ``target_penetration_allowance`` instead of ``gripper_penetration_allowance``.

    Inside ``other_joints_held()`` (an IK solve or a plan: nothing steps physics) the copy gets the
    robot's other joints once and then only ``q`` per query, instead of reading and setting every
    movable joint per query; the answers are the same."""

    def __init__(self, client: int, robot: Robot, gripper_penetration_allowance: float,
                 target_penetration_allowance: float | None = None, backend: str = "pybullet"):
        if backend not in COLLISION_BACKENDS:
            raise ValueError(f"arm collision backend {backend!r}: choose one of {', '.join(COLLISION_BACKENDS)}")
        self.client, self.robot, self.backend = client, robot, backend
        self.target_body: int | None = None
        self._target_threshold = -(gripper_penetration_allowance if target_penetration_allowance is None
                                   else target_penetration_allowance)
        self.joints = robot.arm_joint_indices
        self.lower, self.upper = robot.joint_lower[self.joints], robot.joint_upper[self.joints]
        self._limit_low, self._limit_high = self.lower - 1e-9, self.upper + 1e-9
        anchors = self._rigid_anchors()
        shaped = [link for link in anchors if self._has_collision_shape(link)]
        self.moving_links = [link for link in shaped if anchors[link] != BASE_LINK]
        gripper = set(robot.gripper_link_indices)
        self._world_thresholds = {link: -gripper_penetration_allowance if link in gripper else 0.0
                                  for link in self.moving_links}
        self.gripper_links = gripper & set(self.moving_links)
        candidates = self._self_pair_candidates(shaped, anchors)
        self.ignored_pairs = self._pairs_touching_at_default_pose(candidates)
        self.self_pairs = [pair for pair in candidates if pair not in self.ignored_pairs]
        self._self_copy = SelfCollisionCopy(robot.spec.urdf_path, self.self_pairs)
        self._mirrored_joints = movable_joints(client, robot.robot_id)  # head and fingers count too
        self._planning_joints = [int(j) for j in self.joints]
        self._held = 0  # depth of other_joints_held() contexts
        self._coal, self._coal_held = None, False
        if backend == "coal":
            from relmogen.motion_generation.coal_collision import CoalArmCollision

            self._coal = CoalArmCollision(client, robot, self._planning_joints, self.self_pairs)

    # ------------------------------------------------------------------ setup

    def _has_collision_shape(self, link: int) -> bool:
        return bool(p.getCollisionShapeData(self.robot.robot_id, link, physicsClientId=self.client))

    def _rigid_anchors(self) -> dict[int, int]:
        """Each link -> the nearest link at or above it whose joint is a planning joint
        (BASE_LINK if none): links with the same anchor never move relative to each other
        while planning (head and fingers count as rigid)."""
        body, planning = self.robot.robot_id, set(self.joints.tolist())
        anchors = {BASE_LINK: BASE_LINK}
        for link in range(p.getNumJoints(body, physicsClientId=self.client)):
            parent = p.getJointInfo(body, link, physicsClientId=self.client)[16]
            anchors[link] = link if link in planning else anchors[parent]
        return anchors

    def _self_pair_candidates(self, links: list[int], anchors: dict[int, int]) -> list[tuple[int, int]]:
        body = self.robot.robot_id
        parent_anchor = {a: (anchors[p.getJointInfo(body, a, physicsClientId=self.client)[16]]
                             if a != BASE_LINK else None) for a in set(anchors.values())}
        arm_anchors = set(self.joints[1:].tolist())  # the 7 arm joints (not the torso)

        def adjacent(a: int, b: int) -> bool:
            return a == b or parent_anchor[a] == b or parent_anchor[b] == a

        return [(a, b) for a, b in itertools.combinations(links, 2)
                if (anchors[a] in arm_anchors or anchors[b] in arm_anchors)
                and not adjacent(anchors[a], anchors[b])]

    def _pairs_touching_at_default_pose(self, pairs: list[tuple[int, int]]) -> set[tuple[int, int]]:
        spec = self.robot.spec
        saved = self.robot.joint_state_vector()
        self.robot.set_joint_positions(self.joints, [spec.default_torso, *spec.default_arm_pose])
        touching = {pair for pair in pairs if self._links_touch(*pair)}
        self._restore(saved)
        return touching

    def _restore(self, saved: tuple[Config, Config]) -> None:
        for j, q, v in zip(self.joints, *saved):
            p.resetJointState(self.robot.robot_id, int(j), float(q), float(v), physicsClientId=self.client)

    # ------------------------------------------------------------------ queries

    def _links_touch(self, a: int, b: int) -> bool:
        body = self.robot.robot_id
        return bool(p.getClosestPoints(body, body, 0.0, linkIndexA=a, linkIndexB=b, physicsClientId=self.client))

    def within_limits(self, q: Config) -> bool:
        return bool(((q >= self._limit_low) & (q <= self._limit_high)).all())

    def current_pose_in_collision(self) -> bool:
        return self._hits_world() or self._hits_itself()

    def _hits_world(self) -> bool:
        """One broad+narrow phase over the whole world, then the arm's contacts."""
        body, client = self.robot.robot_id, self.client
        p.performCollisionDetection(physicsClientId=client)
        for contact in p.getContactPoints(bodyA=body, physicsClientId=client):
            link, other = contact[3], contact[2]
            threshold = self._world_thresholds.get(link)
            if threshold is None or other == body:
                continue
            if other == self.target_body and link in self.gripper_links:
                threshold = self._target_threshold
            if contact[8] < threshold:
                return True
        return False

    def _hits_itself(self) -> bool:
        joints = self._mirrored_joints
        states = p.getJointStates(self.robot.robot_id, joints, physicsClientId=self.client)
        return self._self_copy.touching(joints, [state[0] for state in states])

    @contextmanager
    def other_joints_held(self) -> Iterator[None]:
        """Queries in this block may assume the robot's joints other than the planning joints stay
        where they are now (the copy is given them once here)."""
        if not self._held:
            if self._coal is None:
                self._hits_itself()  # mirrors every movable joint onto the copy
            self._coal_held = False  # Coal's geometry is built at the block's first query, if any
        self._held += 1
        try:
            yield
        finally:
            self._held -= 1

    def __call__(self, q: Config) -> bool:
        """Sets the planning joints (the caller restores them) and checks; True = collision."""
        if not self.within_limits(q):
            return True
        if self._held and self._coal is not None:
            if not self._coal_held:
                self._coal.hold(self._world_thresholds, self.gripper_links, self.target_body, self._target_threshold)
                self._coal_held = True
            return self._coal.collides(q)
        self.robot.set_joint_positions(self.joints, q)
        if not self._held:
            return self.current_pose_in_collision()
        return self._hits_world() or self._self_copy.touching(self._planning_joints, np.asarray(q, dtype=np.float64).tolist())


class ArmMotion:
    """Reach a world point with the gripper and push along a world vector (see module doc)."""

    def __init__(self, world_client: int, robot: Robot, config: ArmConfig | None = None):
        self.client, self.robot = world_client, robot
        self.config = config or ArmConfig()
        self.ik_solver = ArmIK(world_client, robot)
        self.checker = ArmCollisionChecker(world_client, robot, self.config.gripper_penetration_allowance,
                                           self.config.target_penetration_allowance, self.config.collision_backend)
        self.time_step = p.getPhysicsEngineParameters(physicsClientId=world_client)["fixedTimeStep"]
        self.planner: Planner = self._make_planner(self.config.planner)
        spec = robot.spec
        self.default_config = np.array([spec.default_torso, *spec.default_arm_pose])

    def set_planner(self, name: str, params=None, **overrides) -> None:
        """Swap the backend (``rrt_connect``, ``lazy_prm``, ``ompl_rrtconnect``, ``ompl_prm``);
        ``params``/``overrides`` go to ``make_planner``."""
        self.planner = self._make_planner(name, params, **overrides)

    def _make_planner(self, name: str, params=None, **overrides) -> Planner:
        if name == "rrt_connect" and params is None:
            overrides = {"iterations": self.config.rrt_iterations, "restarts": self.config.rrt_restarts, **overrides}
        return make_planner(name, params, **overrides)

    # ------------------------------------------------------------------ building blocks

    def collision_fn(self):
        """The planners' collision function; only joint limits when collision checking is off."""
        if self.config.collision_checking:
            return self.checker
        return lambda q: not self.checker.within_limits(np.asarray(q))

    def solve_ik(self, target_xyz: np.ndarray, rng: np.random.Generator, from_current: bool = True):
        cfg = self.config
        valid = (lambda q: not self.checker(q)) if cfg.collision_checking else None
        with self.checker.other_joints_held():
            return self.ik_solver.solve(target_xyz, rng, cfg.ik_iterations, cfg.ik_restarts, cfg.ik_tolerance, valid,
                                        from_current)

    def ik(self, target_xyz: np.ndarray, rng: np.random.Generator) -> Config | None:
        """Planning-joint configuration putting the gripper within tolerance of the target."""
        return self.solve_ik(target_xyz, rng).config

    def plan(self, goal: Config, rng: np.random.Generator):
        """Joint-space plan from the current planning-joint configuration; state restored."""
        saved = self.robot.joint_state_vector()
        problem = PlanningProblem(start=saved[0], goal=goal, lower=self.checker.lower, upper=self.checker.upper,
                                  collision_fn=self.collision_fn(), resolutions=self.config.joint_resolution)
        try:
            with self.checker.other_joints_held():
                return self.planner.plan(problem, rng)
        finally:
            self.ik_solver.restore(saved)

    def body_at(self, point: np.ndarray, probe: float = 0.03) -> int | None:
        """The body whose surface holds ``point``: the first hit of a short ray through it along
        the line from the arm's base (the side the gripper comes from); None if nothing is there."""
        direction = self._approach_direction(point)
        hit = p.rayTest((point - probe * direction).tolist(), (point + probe * direction).tolist(),
                        physicsClientId=self.client)[0]
        body = hit[0]
        return None if body < 0 or body == self.robot.robot_id else int(body)

    def _approach_direction(self, point: np.ndarray) -> np.ndarray:
        direction = np.asarray(point, dtype=np.float64) - self.robot.arm_base_position()
        return direction / max(float(np.linalg.norm(direction)), 1e-9)

    def _gripper_penetration(self, body: int) -> float:
        """How deep (m, >= 0) the gripper links are inside ``body``."""
        gripper = self.checker.gripper_links
        contacts = p.getClosestPoints(self.robot.robot_id, body, 0.0, physicsClientId=self.client)
        return max([-c[8] for c in contacts if c[3] in gripper], default=0.0)

    def _back_out_of(self, body: int | None, approach: np.ndarray, step: float = 0.01) -> None:
        """Kinematically draw the gripper back against ``approach`` until it is no deeper in the
        pushed body than ``gripper_penetration_allowance``, so that the push starts from contact:
        physics would otherwise eject the gripper and fling a light object (a 2 kg box flew
        0.37 m for a 0.2 m push)."""
        cfg = self.config
        if body is None:
            return
        for _ in range(int(np.ceil(cfg.target_penetration_allowance / step)) + 1):
            if self._gripper_penetration(body) <= cfg.gripper_penetration_allowance:
                return
            point = self.robot.end_effector_position() - step * approach
            q = self.ik_solver.track_line(point[None], self.robot.joint_state_vector()[0], cfg.push_ik_iterations)[0]
            self._move_kinematically(q)

    # ------------------------------------------------------------------ the subgoal

    def reach_and_push(self, target_xyz_world, push_vector_world, rng: np.random.Generator,
                       on_physics_steps: PhysicsCallback | None = None,
                       on_reached: Callable[[list[Config]], None] | None = None) -> ArmResult:
        """IK, plan, move to the target, push, come back. ``on_reached(path)`` is called when
        the gripper is at the target, before the push (the task may check it there)."""
        start = time.perf_counter()
        target = np.asarray(target_xyz_world, dtype=np.float64)
        target_body = self.body_at(target)
        exemption_can_help = target_body is not None and self.config.collision_checking
        try:
            for attempt in range(self.config.plan_attempts):
                # The first attempt holds the gripper to gripper_penetration_allowance everywhere;
                # later ones let it sink into the pushed body (target_penetration_allowance).
                self.checker.target_body = target_body if attempt > 0 else None
                ik = self.solve_ik(target, rng, from_current=attempt == 0)
                if ik.config is None and (attempt > 0 or not exemption_can_help):
                    return ArmResult(False, ik.reason, planning_time_s=time.perf_counter() - start,
                                     wall_time_s=time.perf_counter() - start)
                plan = self.plan(ik.config, rng) if ik.config is not None else None
                if plan is not None and plan.success:
                    break
            sunk_into = self.checker.target_body  # the body a solution may be deep in, if any
        finally:
            self.checker.target_body = None
        planning_time = time.perf_counter() - start
        if plan is None or not plan.success:
            reason = ik.reason if plan is None else f"no arm plan: {plan.reason}"
            return ArmResult(False, reason, planning_time_s=planning_time, wall_time_s=time.perf_counter() - start,
                             goal_config=ik.config)
        self._move_kinematically(plan.path[-1])
        if on_reached is not None:
            on_reached(plan.path)
        self._back_out_of(sunk_into, self._approach_direction(target))
        steps, pushed = self._push(push_vector_world, on_physics_steps)
        self._retreat_and_tuck(push_vector_world)
        return ArmResult(True, self._push_outcome(push_vector_world, pushed), planning_time, steps * self.time_step, steps, pushed,
                         time.perf_counter() - start, ik.config, plan.path)

    def _push_outcome(self, push_vector_world, pushed: float) -> str:
        commanded = min(float(np.linalg.norm(push_vector_world)), self.config.push_max_length)
        if pushed < 0.5 * commanded:
            return f"push blocked: gripper moved {pushed:.3f} of {commanded:.3f} m"
        return f"pushed {pushed:.3f} of {commanded:.3f} m"

    def reach_and_push_pixel(self, camera: Camera, frame: CameraFrame, u: int, v: int, push_vector_world,
                             rng: np.random.Generator,
                             on_physics_steps: PhysicsCallback | None = None) -> ArmResult:
        """The same from a pixel of an RGB-D frame (the paper's arm action)."""
        try:
            target = camera.pixel_to_world(frame, u, v)
        except ValueError as error:
            return ArmResult(False, "pixel has no depth" if "depth" in str(error) else str(error))
        return self.reach_and_push(target, push_vector_world, rng, on_physics_steps)

    # ------------------------------------------------------------------ execution

    def _move_kinematically(self, q: Config) -> None:
        """Set the planning joints and hold them there with the motors."""
        self.robot.set_joint_positions(self.robot.arm_joint_indices, q)
        self.robot.command_joint_positions(self.robot.arm_joint_indices, q)

    def _push(self, push_vector_world, on_physics_steps: PhysicsCallback | None) -> tuple[int, float]:
        cfg, robot = self.config, self.robot
        line = make_push_line(robot.end_effector_position(), push_vector_world, cfg.push_max_length)
        if line.length <= 0:
            return 0, 0.0
        start_q = robot.joint_state_vector()[0]
        targets = self.ik_solver.track_line(line.points(cfg.push_points), start_q, cfg.push_ik_iterations)
        forces = robot.joint_max_force[robot.arm_joint_indices] * cfg.push_force_scale
        with base_held_still(self.client, robot, cfg.base_hold_force), physics_sub_steps(self.client, cfg.push_sub_steps):
            steps = follow_joint_targets(self.client, robot, targets, forces, cfg.push_position_gain,
                                         cfg.push_steps_per_point, on_physics_steps)
            steps += step_physics(self.client, cfg.push_settle_steps, on_physics_steps)
        return steps, line.progress(robot.end_effector_position())

    def _retreat_and_tuck(self, push_vector_world) -> None:
        """Back off along the push line from where the gripper actually is (so a kinematic jump
        never lands inside the pushed object), then the default pose, held by the motors."""
        cfg, robot = self.config, self.robot
        back = -np.asarray(push_vector_world, dtype=np.float64)
        line = make_push_line(robot.end_effector_position(), back, cfg.retreat_distance)
        if line.length > 0 and cfg.retreat_points > 0:
            path = self.ik_solver.track_line(line.points(cfg.retreat_points), robot.joint_state_vector()[0],
                                             cfg.push_ik_iterations)
            robot.set_joint_positions(robot.arm_joint_indices, path[-1])
        self._move_kinematically(self.default_config)
        # A push can force the fingers past their limits; a bent finger would make the tucked
        # arm touch the torso and every later arm plan fail.
        open_fingers = robot.spec.gripper_open
        robot.set_joint_positions(robot.gripper_joint_indices, open_fingers)
        robot.command_joint_positions(robot.gripper_joint_indices, open_fingers)
