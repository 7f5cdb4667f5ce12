"""Subgoal action spaces: one environment step executes one subgoal through the motion generator.

``subgoal-r`` (SGP-R, continuous; the original 8-D meaning, facts sheet section 5):
    a[0] > 0 selects a base subgoal, otherwise an arm subgoal (tasks that use only one part
    ignore it). Base: polar angle a[1] * 110 deg, distance a[2] + 1 (0-2 m), yaw change
    a[3] * pi, in the robot frame. Arm: image row (a[4] + 1) / 2 * H, column (a[5] + 1) / 2 * W,
    push vector (a[6], a[7]) * 0.25 m in the base frame (clipped to 0.25 m).

``subgoal-d`` (SGP-D, discrete over dense Q x Q maps; by default Q = S / 4, the paper's 32 at
    128 px; ``qmap_size`` sets Q for any S it divides, e.g. 32 at 64 px, so that each cell covers
    c = S / Q image pixels a side):
    index in [0, L*Q*Q): base map; (l, i, j) = unravel(index, (L, Q, Q)); the goal is the
        centre of cell (i, j) of the 5 m local map (i along x forward, j along y left, as in
        ``LocalMap``) with final yaw -pi + l * 2pi / L in the robot frame.
    index in [L*Q*Q, (L+K)*Q*Q): arm map; (k, i, j) = unravel(index - L*Q*Q, (K, Q, Q)); the
        image pixel (row c*i + c//2, column c*j + c//2) with a horizontal push of ``push_length`` m
        in direction k, which depends on ``push_frame``:
          ``base`` (the paper's): base-frame heading k * 2pi / K;
          ``surface`` (ours): heading -pi/2 + (k + 1/2) pi / K from the inward horizontal normal
          of the surface seen at the pixel, so every bin pushes into it, at 15 deg steps.
          Cells whose surface is not steep (normal more than 45 deg from horizontal: floor,
          table tops) or whose normal is undefined are masked: no horizontal push goes into
          them.
    The observation adds ``local_map`` (S, S, C) uint8: channel 0 the occupancy map
    (FREE 0 / UNKNOWN 128 / OCCUPIED 255), and for navigation tasks channel 1 with the goal
    (255) and the shortest-path waypoints (128) drawn on it. ``info["base_mask"]`` is a
    (Q, Q) bool array of base cells where the robot's footprint is free on the map;
    ``info["arm_mask"]`` a (Q, Q) bool array of arm cells whose pixel has depth and sees a point
    within the robot's ``arm_reach`` of its first arm joint (beyond it no plan is ever found),
    and with ``push_frame="surface"`` a steep surface. With ``reach_mask="measured"`` (ours) the
    point must lie in the robot's measured reachability map instead (``robots/reachability.py``:
    the sphere also allows points with no IK solution, 15% of the allowed arm cells in
    ArrangeKitchenMM, ``relmogen analyse reach-mask``).

Rewards are the sum of the low-level (0.1 s) rewards accrued while the subgoal executed.
When no plan is found the step is a no-op: nothing moves, the reward is 0, and it counts.
``noop_cost`` > 0 (ours, off by default) adds the reward term ``no_op`` = -cost to a subgoal
that executed nothing: no plan, or a base plan stopped before its first waypoint. A no-op
leaves the observation unchanged, so a deterministic policy that chose one repeats it; the
cost teaches the critic that it loses the step.

``subgoal_feedback`` (ours, off by default) shows the policy its previous subgoal and whether
it executed nothing (``executed_nothing``). A no-op then changes the observation, so the policy
can choose differently after one instead of repeating it.
    ``subgoal-r``: the observation ``last_subgoal`` (9,) float32, the previous action (clipped
    to [-1, 1]; zeros after a reset) and 1.0 if it executed nothing, else 0.0.
    ``subgoal-d``: two more ``local_map`` channels after the sensed ones, each the S x S frame
    of one Q map: the previous base subgoal's cell (i, j) in the base maps' local-map frame, and
    the previous arm subgoal's cell (i, j) in the arm maps' camera-image frame, drawn as its
    c x c pixel square, 255 if it executed something and 128 if it executed nothing (no plan, a
    base plan stopped before its first waypoint, or a part the task does not use). Only the
    previous subgoal is drawn (the other part's channel is zero; both are zero after a reset);
    the cell is where the action chose it, in the frame of the observation it was chosen in.
    Its yaw or push bin is not drawn. The Q-map network's map branch takes every ``local_map``
    channel, so the feedback reaches each cell's Q values without any other change.

``arm_rrt`` = (iterations, restarts) of the arm's RRT-Connect; the default (20, 2) is the
paper's planner budget (``ArmConfig.rrt_iterations``). ``arm_collision_backend`` answers the arm's
collision queries inside IK solves and plans (``ArmConfig.collision_backend``: coal or pybullet).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
from gymnasium import spaces

from relmogen.envs.controls import Control, StepOutcome, validate_action
from relmogen.motion_generation.base_planner import FootprintChecker, wrap_angle
from relmogen.motion_generation.arm import ArmConfig
from relmogen.motion_generation.generator import MotionGenerator, MotionGeneratorConfig, SubgoalResult
from relmogen.robots.reachability import load_reachability

if TYPE_CHECKING:
    from relmogen.envs.relmogen_env import RelmogenEnv

BASE_ANGLE_RANGE = np.deg2rad(110.0)
PUSH_MAX = 0.25
YAW_BINS = 12  # L
PUSH_BINS = 12  # K
Q_DOWNSAMPLE = 4  # the paper's image pixels per Q-map cell (128 px -> 32 x 32); ``qmap_size`` overrides
LOCAL_MAP_M = 5.0  # side of the base Q map's local map, centred on the robot
PUSH_FRAMES = ("base", "surface")
REACH_MASKS = ("sphere", "measured")
STEEP_NORMAL = np.cos(np.deg2rad(45.0))  # least horizontal part of a unit normal a push can go into


class RewardAccumulator:
    """Sums task rewards at 0.1 s boundaries of simulated time while the MG executes;
    ``close`` adds the rest and the per-decision terms once."""

    def __init__(self, env: RelmogenEnv):
        self.env = env
        self.total, self.terms, self.pending = 0.0, {}, 0.0

    def tick(self, dt: float) -> None:
        self.env.sim_time += dt
        self.env.task.after_control_step()
        if self.env.frame_hook is not None:
            self.env.frame_hook()
        self.pending += dt
        if self.pending >= 0.1 - 1e-9:
            self.flush()

    def close(self) -> RewardAccumulator:
        self.flush(decision=True)
        return self

    def flush(self, decision: bool = False) -> None:
        reward, terms = self.env.task.reward(decision)
        self.total += reward
        for key, value in terms.items():
            self.terms[key] = self.terms.get(key, 0.0) + value
        self.pending = 0.0


def arm_base_distance(env: RelmogenEnv, points) -> np.ndarray:
    """Distance (m) of world points ``(..., 3)`` from the arm's base (``robot.arm_base_position``);
    NaN points (pixels without depth) are infinitely far."""
    distance = np.linalg.norm(np.asarray(points, dtype=np.float64) - env.robot.arm_base_position(), axis=-1)
    return np.nan_to_num(distance, nan=np.inf)


def within_arm_reach(env: RelmogenEnv, points) -> np.ndarray:
    """Which world points ``(..., 3)`` are within ``robot.spec.arm_reach`` of the arm's base:
    beyond it no arm plan is ever found (SGP-D masks those cells, both controls skip IK there)."""
    return arm_base_distance(env, points) <= env.robot.spec.arm_reach


def executed_nothing(result: SubgoalResult) -> bool:
    """No plan, or a plan stopped before its first waypoint (no simulated time passed)."""
    return not result.success or result.sim_time_s <= 0.0


class SubgoalControl(Control):
    """Shared execution of base and arm subgoals; subclasses decode actions."""

    name = "subgoal"

    def __init__(self, env: RelmogenEnv, base_planner: str = "rrt_connect", arm_planner: str = "rrt_connect",
                 arm_collision: bool = True, base_goal: str = "strict", noop_cost: float = 0.0,
                 arm_rrt: tuple[int, int] = (ArmConfig.rrt_iterations, ArmConfig.rrt_restarts),
                 base_goal_clearance: float = 0.0, arm_collision_backend: str = ArmConfig.collision_backend):
        if not (np.isfinite(noop_cost) and noop_cost >= 0):
            raise ValueError(f"noop_cost must be a finite number >= 0, got {noop_cost!r}")
        self.env, self.noop_cost = env, float(noop_cost)
        self.episode_steps = env.task.subgoal_steps
        self.parts = env.task.subgoal_parts
        config = MotionGeneratorConfig(base_planner=base_planner, arm_planner=arm_planner,
                                       arm_collision_checking=arm_collision, base_goal=base_goal,
                                       base_goal_clearance=float(base_goal_clearance),
                                       arm=ArmConfig(rrt_iterations=int(arm_rrt[0]), rrt_restarts=int(arm_rrt[1]),
                                                     collision_backend=arm_collision_backend))
        self.mg = MotionGenerator(env, config)

    def execute_base(self, goal_robot_frame: np.ndarray) -> tuple[SubgoalResult, RewardAccumulator]:
        rewards = RewardAccumulator(self.env)
        result = self.mg.move_base(goal_robot_frame, self.env.np_random, rewards.tick, ranges=self.env.observed_scan())
        return result, rewards.close()

    def execute_arm(self, pixel_row: int, pixel_col: int, push_base: np.ndarray):
        """Reach the point seen at the pixel and push. A pixel without depth, or one whose point
        is beyond the arm's reach (``within_arm_reach``), is a no-op without any IK."""
        rewards = RewardAccumulator(self.env)
        env = self.env
        if not env.last_frame.has_point(pixel_row, pixel_col):
            return self._arm_no_op("pixel has no depth", rewards)
        point = env.camera.pixel_to_world(env.last_frame, pixel_col, pixel_row)
        if not within_arm_reach(env, point):
            return self._arm_no_op(f"point {float(arm_base_distance(env, point)):.2f} m from the arm base, "
                                   f"beyond its reach of {env.robot.spec.arm_reach:.2f} m", rewards)
        yaw = env.robot.base_pose()[2]
        push_world = np.array([np.cos(yaw) * push_base[0] - np.sin(yaw) * push_base[1],
                               np.sin(yaw) * push_base[0] + np.cos(yaw) * push_base[1], 0.0])
        result = self.mg.reach_and_push(point, push_world, env.np_random, rewards.tick)
        return result, rewards.close()

    def _arm_no_op(self, reason: str, rewards: RewardAccumulator) -> tuple[SubgoalResult, RewardAccumulator]:
        return SubgoalResult("arm", self.mg.config.arm_planner, False, reason), rewards.close()

    def decode_continuous(self, action) -> tuple[str, tuple]:
        """A ``subgoal-r`` action -> ("base", (robot-frame goal x, y, yaw change),) or
        ("arm", (pixel row, pixel column, base-frame push vector))."""
        a = np.clip(validate_action(action, (8,)), -1.0, 1.0)
        if self.uses_base(a):
            angle, distance = a[1] * BASE_ANGLE_RANGE, a[2] + 1.0
            return "base", (np.array([distance * np.cos(angle), distance * np.sin(angle), a[3] * np.pi]),)
        push = a[6:8] * PUSH_MAX
        norm = float(np.linalg.norm(push))
        if norm > PUSH_MAX:
            push *= PUSH_MAX / norm
        return "arm", (*self.arm_pixel(a), push)

    def uses_base(self, action: np.ndarray) -> bool:
        return self.parts == ("base",) or (self.parts != ("arm",) and action[0] > 0.0)

    def arm_pixel(self, action: np.ndarray) -> tuple[int, int]:
        """(row, col) of the image pixel a ``subgoal-r`` arm action reaches for."""
        height, width = self.env.last_frame.depth.shape
        row = min(int((action[4] + 1.0) / 2.0 * height), height - 1)
        col = min(int((action[5] + 1.0) / 2.0 * width), width - 1)
        return row, col

    def outcome(self, result: SubgoalResult, rewards: RewardAccumulator, **extra: Any) -> StepOutcome:
        task = self.env.task
        termination = "success" if task.terminates_on_success() and task.is_success() else None
        info = dict(result.as_info(), **extra)
        if self.noop_cost and executed_nothing(result):
            rewards.total -= self.noop_cost
            rewards.terms["no_op"] = rewards.terms.get("no_op", 0.0) - self.noop_cost
        return StepOutcome(rewards.total, termination, rewards.terms, info)


FEEDBACK_DIM = 9  # ``last_subgoal``: the 8-D action and the executed-nothing flag


class SubgoalRControl(SubgoalControl):
    name = "subgoal-r"

    def __init__(self, env: RelmogenEnv, subgoal_feedback: bool = False, **options: Any):
        super().__init__(env, **options)
        self.action_space = spaces.Box(-1.0, 1.0, (8,), np.float32)
        self.subgoal_feedback = bool(subgoal_feedback)
        self.reset()

    def reset(self) -> None:
        self._last_subgoal = np.zeros(FEEDBACK_DIM, dtype=np.float32)

    def step(self, action) -> StepOutcome:
        part, target = self.decode_continuous(action)
        result, rewards = self.execute_base(*target) if part == "base" else self.execute_arm(*target)
        self._last_subgoal = np.append(np.clip(np.asarray(action, dtype=np.float32), -1.0, 1.0),
                                       np.float32(executed_nothing(result)))
        return self.outcome(result, rewards)

    def extra_observation(self) -> dict[str, np.ndarray]:
        return {"last_subgoal": self._last_subgoal.copy()} if self.subgoal_feedback else {}

    def extra_observation_space(self) -> dict[str, spaces.Space]:
        if not self.subgoal_feedback:
            return {}
        return {"last_subgoal": spaces.Box(-1.0, 1.0, (FEEDBACK_DIM,), np.float32)}


def decode_indices(indices, q: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """SGP-D action indices (any shape; an int, a list, a NumPy array or an integer torch tensor,
    whose type the results keep) -> (is_arm, yaw or push bin, cell row i, cell column j): the L
    base maps come first, then the K arm maps, each Q x Q."""
    if not hasattr(indices, "shape"):
        indices = np.asarray(indices)
    base_size = YAW_BINS * q * q
    is_arm = indices >= base_size
    within_maps = indices - base_size * is_arm
    bin_, cell = within_maps // (q * q), within_maps % (q * q)
    return is_arm, bin_, cell // q, cell % q


def encode_indices(is_arm, bin_, i, j, q: int):
    """The inverse of ``decode_indices``, for the same types (ints, NumPy arrays, integer torch tensors)."""
    return is_arm * (YAW_BINS * q * q) + (bin_ * q + i) * q + j


def qmap_size_for(image_size: int, qmap_size: int | None = None) -> int:
    """Q, the side of SGP-D's Q maps: ``qmap_size``, or image_size / 4 (the paper's ratio) when None.
    Q must divide the image size, so that every cell covers the same square of pixels."""
    if qmap_size is None:
        if image_size % Q_DOWNSAMPLE:
            raise ValueError(f"subgoal-d needs an image size divisible by {Q_DOWNSAMPLE}, got {image_size}")
        return image_size // Q_DOWNSAMPLE
    if int(qmap_size) < 1 or image_size % int(qmap_size):
        raise ValueError(f"qmap_size {qmap_size} must be a positive divisor of the image size {image_size}")
    return int(qmap_size)


FEEDBACK_MAP_CHANNELS = ("base", "arm")  # SGP-D's ``subgoal_feedback`` channels of ``local_map``, in order
FEEDBACK_EXECUTED = 255  # the previous subgoal's cell when it executed something
FEEDBACK_NO_OP = 128  # ... when it executed nothing


class SubgoalDControl(SubgoalControl):
    name = "subgoal-d"

    def __init__(self, env: RelmogenEnv, push_length: float = PUSH_MAX, push_frame: str = "base",
                 qmap_size: int | None = None, reach_mask: str = "sphere", subgoal_feedback: bool = False,
                 **options: Any):
        if push_frame not in PUSH_FRAMES:
            raise ValueError(f"unknown push_frame {push_frame!r}; valid: {', '.join(PUSH_FRAMES)}")
        if reach_mask not in REACH_MASKS:
            raise ValueError(f"unknown reach_mask {reach_mask!r}; valid: {', '.join(REACH_MASKS)}")
        self._reachability = load_reachability(env.robot.spec) if reach_mask == "measured" else None
        super().__init__(env, **options)
        size = env.camera.intrinsics.width
        self.map_pixels, self.q = size, qmap_size_for(size, qmap_size)
        self.cell_pixels = size // self.q  # image pixels per Q-map cell, a side
        self.push_length, self.push_frame = float(push_length), push_frame
        self.num_base = YAW_BINS * self.q * self.q
        self.action_space = spaces.Discrete(self.num_base + PUSH_BINS * self.q * self.q)
        self.map_channels = 2 if env.task.has_map_marks else 1  # sensed: occupancy (and the task's marks)
        self.subgoal_feedback = bool(subgoal_feedback)
        self.feedback_channels = len(FEEDBACK_MAP_CHANNELS) if self.subgoal_feedback else 0
        self.reset()
        self._base_mask = np.ones((self.q, self.q), dtype=bool)
        self._arm_mask = np.ones((self.q, self.q), dtype=bool)
        self._inward_heading = np.zeros((self.q, self.q))  # base frame, into each cell's surface

    # ------------------------------------------------------------------- index mapping
    def decode(self, index: int) -> tuple[str, int, int, int]:
        """Action index -> (part, bin, i, j)."""
        is_arm, bin_, i, j = decode_indices(index, self.q)
        return "arm" if is_arm else "base", int(bin_), int(i), int(j)

    def encode(self, part: str, bin_: int, i: int, j: int) -> int:
        bins = YAW_BINS if part == "base" else PUSH_BINS
        if not (0 <= bin_ < bins and 0 <= i < self.q and 0 <= j < self.q):
            raise ValueError(f"no {part} action with bin {bin_} at cell ({i}, {j}): {bins} bins, {self.q} x {self.q} cells")
        return int(encode_indices(part != "base", bin_, i, j, self.q))

    def reset(self) -> None:
        self._feedback = np.zeros((self.map_pixels, self.map_pixels, self.feedback_channels), dtype=np.uint8)

    def step(self, action) -> StepOutcome:
        index = self._validate(action)
        part, bin_, i, j = self.decode(index)
        result, rewards = self._execute(part, bin_, i, j)
        if self.subgoal_feedback:
            self._remember_subgoal(part, i, j, executed_nothing(result))
        return self.outcome(result, rewards, action_index=index)

    def _execute(self, part: str, bin_: int, i: int, j: int) -> tuple[SubgoalResult, RewardAccumulator]:
        if part not in self.parts:
            skipped = SubgoalResult(part, "none", False, f"{part} subgoals are not used by {self.env.task.name}")
            return skipped, RewardAccumulator(self.env).close()
        if part == "base":
            return self.execute_base(self.base_goal(bin_, i, j))
        return self.execute_arm(*self.cell_pixel(i, j), self.push_vector(bin_, i, j))

    def _remember_subgoal(self, part: str, i: int, j: int, no_op: bool) -> None:
        """``subgoal_feedback``: only this subgoal's cell, on its part's channel, valued by its outcome."""
        c = self.cell_pixels
        self._feedback[:] = 0
        self._feedback[c * i:c * (i + 1), c * j:c * (j + 1), FEEDBACK_MAP_CHANNELS.index(part)] = (
            FEEDBACK_NO_OP if no_op else FEEDBACK_EXECUTED)

    def base_goal(self, bin_: int, i: int, j: int) -> np.ndarray:
        """Robot-frame (x, y, yaw change) of base action (bin_, i, j): its local-map cell's centre."""
        cell, half = LOCAL_MAP_M / self.q, LOCAL_MAP_M / 2
        return np.array([(i + 0.5) * cell - half, (j + 0.5) * cell - half, -np.pi + bin_ * 2 * np.pi / YAW_BINS])

    def cell_pixel(self, i: int, j: int) -> tuple[int, int]:
        """(row, col) of the image pixel arm cell (i, j) reaches for: the cell's centre pixel."""
        c = self.cell_pixels
        return c * i + c // 2, c * j + c // 2

    def pixel_cell(self, row: int, col: int) -> tuple[int, int]:
        """The arm cell (i, j) holding image pixel (row, col)."""
        return row // self.cell_pixels, col // self.cell_pixels

    def push_vector(self, bin_: int, i: int, j: int) -> np.ndarray:
        """Base-frame push of arm action (bin_, i, j): ``push_length`` m along ``push_heading``."""
        angle = self.push_heading(bin_, i, j)
        return self.push_length * np.array([np.cos(angle), np.sin(angle)])

    def nearest_index(self, subgoal_r_action) -> int:
        """The discrete action nearest to a ``subgoal-r`` action in the current observation (the
        cell holding its base goal or pixel, the nearest yaw or push bin): how a scripted
        subgoal-r oracle acts through this control."""
        part, target = self.decode_continuous(subgoal_r_action)
        if part == "base":
            (goal,) = target
            i, j = np.clip(np.floor((goal[:2] + LOCAL_MAP_M / 2) * self.q / LOCAL_MAP_M).astype(int), 0, self.q - 1)
            yaw_bin = int(np.round((wrap_angle(goal[2]) + np.pi) * YAW_BINS / (2 * np.pi))) % YAW_BINS
            return self.encode("base", yaw_bin, int(i), int(j))
        row, col, push = target
        i, j = self.pixel_cell(row, col)
        return self.encode("arm", self.nearest_push_bin(float(np.arctan2(push[1], push[0])), i, j), i, j)

    def nearest_push_bin(self, heading: float, i: int, j: int) -> int:
        """The push bin at arm cell (i, j) whose heading (``push_heading``) is nearest ``heading``."""
        if self.push_frame == "base":
            return int(np.round(heading * PUSH_BINS / (2 * np.pi))) % PUSH_BINS
        offset = wrap_angle(heading - self._inward_heading[i, j])
        return int(np.clip(np.round((offset + np.pi / 2) * PUSH_BINS / np.pi - 0.5), 0, PUSH_BINS - 1))

    def push_heading(self, bin_: int, i: int, j: int) -> float:
        """Base-frame heading of push bin ``bin_`` at arm cell (i, j) in the current observation."""
        if self.push_frame == "base":
            return bin_ * 2 * np.pi / PUSH_BINS
        return float(self._inward_heading[i, j]) - np.pi / 2 + (bin_ + 0.5) * np.pi / PUSH_BINS

    def _validate(self, action) -> int:
        arr = np.asarray(action)
        integral = arr.size == 1 and (
            np.issubdtype(arr.dtype, np.integer)
            or (np.issubdtype(arr.dtype, np.floating) and np.isfinite(arr).all() and float(arr).is_integer())
        )
        if not integral:
            raise ValueError(f"subgoal-d action must be one integer index, got {action!r}")
        index = int(arr)
        if not 0 <= index < self.action_space.n:
            raise ValueError(f"subgoal-d action {index} outside [0, {self.action_space.n})")
        return index

    # ------------------------------------------------------------------ observations
    def extra_observation(self) -> dict[str, np.ndarray]:
        ranges = self.env.last_scan  # the observation's own scan, taken just before
        self._base_mask = self._free_cells(self.mg.local_map(ranges))
        self._arm_mask = self._arm_cells()
        obs_map = self.mg.local_map(ranges, resolution=LOCAL_MAP_M / self.map_pixels)
        channels = [obs_map.grid]
        if self.map_channels == 2:
            channels.append(_draw_marks(obs_map, *self.env.task.map_marks()))
        channels.extend(np.moveaxis(self._feedback, -1, 0))  # none unless ``subgoal_feedback``
        return {"local_map": np.stack(channels, axis=-1)}

    def extra_observation_space(self) -> dict[str, spaces.Space]:
        shape = (self.map_pixels, self.map_pixels, self.map_channels + self.feedback_channels)
        return {"local_map": spaces.Box(0, 255, shape, np.uint8)}

    def extra_info(self) -> dict[str, np.ndarray]:
        return {"base_mask": self._base_mask.copy(), "arm_mask": self._arm_mask.copy()}

    def _arm_cells(self) -> np.ndarray:
        """Q x Q arm cells whose pixel sees a point within the arm's reach (and, in the surface
        frame, a steep surface; its inward heading is kept for ``push_heading``)."""
        env, frame = self.env, self.env.last_frame
        rows, cols = self.cell_pixel(*np.meshgrid(np.arange(self.q), np.arange(self.q), indexing="ij"))
        points, has_depth = env.camera.pixels_to_world(frame, cols, rows)
        if self._reachability is None:
            reachable = has_depth & within_arm_reach(env, points)
        else:
            reachable = has_depth & self._reachability.contains_world(points, env.robot.base_pose())
        if self.push_frame == "base":
            return reachable
        normals = env.camera.surface_normals(frame, cols, rows)
        steep = np.nan_to_num(np.hypot(normals[..., 0], normals[..., 1])) >= STEEP_NORMAL
        ray = np.nan_to_num(points - frame.position)
        inward = np.where(steep, np.arctan2(-normals[..., 1], -normals[..., 0]), np.arctan2(ray[..., 1], ray[..., 0]))
        self._inward_heading = inward - env.robot.base_pose()[2]
        return reachable & steep

    def _free_cells(self, local_map) -> np.ndarray:
        """Q x Q cells whose centre leaves the footprint clear of obstacles on ``local_map``."""
        cell = LOCAL_MAP_M / self.q
        centres = (np.arange(self.q) + 0.5) * cell - LOCAL_MAP_M / 2
        points = np.stack(np.meshgrid(centres, centres, indexing="ij"), axis=-1)
        cells = np.clip(local_map.point_to_cell(points), 0, local_map.size - 1)
        clearance = FootprintChecker(local_map, self.env.robot.spec.base_radius).clearance_grid
        return clearance[cells[..., 0], cells[..., 1]] >= self.env.robot.spec.base_radius


def _draw_marks(local_map, points: np.ndarray, values: np.ndarray) -> np.ndarray:
    """A channel with ``values`` drawn at robot-frame ``points`` (3 x 3 cells each)."""
    channel = np.zeros_like(local_map.grid)
    n = channel.shape[0]
    for (ci, cj), value in zip(local_map.point_to_cell(points), values):
        rows, cols = slice(max(ci - 1, 0), min(ci + 2, n)), slice(max(cj - 1, 0), min(cj + 2, n))
        channel[rows, cols] = np.maximum(channel[rows, cols], value)
    return channel
