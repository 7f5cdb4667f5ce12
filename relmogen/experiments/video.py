"""Annotated videos of an episode (``relmogen eval --video``, ``relmogen demo --video``).

Each frame is the overhead view (``views.overhead_camera``: high above the robot, so walls do
not hide it) with an inset of the robot's camera image the policy chose on, and overlays: the
step, the subgoal type, the subgoal itself (a base goal pose as an arrow on the floor of the
overhead view; an arm pixel and its push as a ring and an arrow on the camera inset), the
step's reward and whether a plan was found, or why not.

While a subgoal executes, at most ``FRAMES_PER_SUBGOAL`` frames are taken, at least
``SUBGOAL_FRAME_PERIOD_S`` of simulated time apart, then one with its outcome. Joint-velocity
episodes get a frame every ``JOINT_STEPS_PER_FRAME`` steps and at the end.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from PIL import Image, ImageDraw, ImageFont

from relmogen.experiments.rollout import FrameRecorder
from relmogen.simulation.frames import to_world
from relmogen.simulation.views import ViewCamera, overhead_camera, render

VIDEO_SIZE = (512, 384)  # width, height: multiples of 16, as H.264 wants
VIDEO_FPS = 5
INSET_SIZE = 160
MARGIN = 6
FRAMES_PER_SUBGOAL = 3
SUBGOAL_FRAME_PERIOD_S = 1.0
JOINT_STEPS_PER_FRAME = 5
LOCAL_MAP_M = 5.0  # side of the local map SGP-D's base cells divide (subgoal_controls.py)
HEADING_ARROW_M = 0.6
PUSH_ARROW_MIN_PX = 28  # a 0.25 m push a metre or two away spans only a few pixels: its direction is what shows
GOAL_COLOUR = (255, 200, 0, 255)
ARM_COLOUR = (0, 255, 255, 255)
PANEL_COLOUR = (0, 0, 0, 160)
TEXT_COLOUR = (255, 255, 255, 255)
FONT = ImageFont.load_default(size=15)


@dataclass(frozen=True)
class Subgoal:
    """A chosen subgoal as drawn: a base goal pose in the world (x, y, yaw), or an arm pixel
    (row, column) of the robot's image, the world point seen there and the image position its
    push ends at (None when the pixel has no depth or the end is behind the camera)."""

    part: str
    base_goal: np.ndarray | None = None
    pixel: tuple[int, int] | None = None
    arm_point: np.ndarray | None = None
    push_end: tuple[float, float] | None = None


def chosen_subgoal(env, action) -> Subgoal | None:
    """The subgoal ``action`` stands for in the environment's current observation; None for
    joint velocities."""
    control = env.control
    if control.name == "subgoal-r":
        part, target = control.decode_continuous(action)
    elif control.name == "subgoal-d":
        part, target = _discrete_target(control, int(action))
    else:
        return None
    if part == "base":
        return Subgoal("base", base_goal=_world_pose(env, target[0]))
    return _arm_subgoal(env, *target)


def _discrete_target(control, index: int) -> tuple[str, tuple]:
    """An SGP-D index as ``decode_continuous`` returns a subgoal-r action: the robot-frame base
    goal (the centre of its local-map cell, its yaw bin), or the pixel and base-frame push."""
    part, bin_, i, j = control.decode(index)
    if part == "base":
        return part, (control.base_goal(bin_, i, j),)
    return part, (*control.cell_pixel(i, j), control.push_vector(bin_, i, j))


def _world_pose(env, goal_robot_frame: np.ndarray) -> np.ndarray:
    pose = env.robot.base_pose()
    x, y = to_world(goal_robot_frame[:2], pose)
    return np.array([x, y, pose[2] + goal_robot_frame[2]])


def _arm_subgoal(env, row: int, col: int, push_base: np.ndarray) -> Subgoal:
    """The arm subgoal at pixel (row, col): the point seen there and where its push ends on the image."""
    frame = env.last_frame
    if not frame.has_point(row, col):
        return Subgoal("arm", pixel=(row, col))
    point = env.camera.pixel_to_world(frame, col, row)
    push_world = to_world(push_base, (0.0, 0.0, env.robot.base_pose()[2]))
    end = point + np.append(push_world, 0.0)
    u, v, depth = env.camera.intrinsics.project(frame.rotation.T @ (end - frame.position))
    return Subgoal("arm", pixel=(row, col), arm_point=point, push_end=(v, u) if depth > 0 else None)


def outcome_text(reward: float, info: dict) -> list[str]:
    """The overlay lines after a step: its reward, the plan (found, or why not) and the episode's end."""
    lines = [f"reward {reward:+.2f}"]
    if "plan_found" in info:
        reason = info.get("reason") or ""
        lines.append(f"plan found{': ' + reason if reason else ''}" if info["plan_found"] else f"no plan: {reason}")
    if "metrics" in info:
        lines.append(f"episode over: {info.get('termination') or 'time limit'}, "
                     f"success {bool(info['metrics'].get('success'))}")
    return lines


class AnnotatedRecorder(FrameRecorder):
    """Records an episode as annotated frames (see the module docstring)."""

    def __init__(self, size: tuple[int, int] = VIDEO_SIZE):
        super().__init__()
        self.size = size
        self.step, self.frames_this_step = 0, 0
        self.subgoal: Subgoal | None = None
        self.camera_image: np.ndarray | None = None
        self.lines: list[str] = []

    def start(self, env, obs: dict) -> None:
        self.camera_image, self.lines = obs["rgb"], ["start"]
        super().start(env, obs)

    def before_step(self, obs: dict, action) -> None:
        self.step += 1
        self.subgoal = chosen_subgoal(self.env, action)
        self.camera_image, self.frames_this_step = obs["rgb"], 0
        self.last_frame_time = self.env.sim_time
        self.lines = [f"{self._part()}: executing"]

    def during_step(self) -> None:
        if self.frames_this_step < FRAMES_PER_SUBGOAL and \
                self.env.sim_time - self.last_frame_time >= SUBGOAL_FRAME_PERIOD_S:
            self.frames_this_step += 1
            self.frames.append(self.frame())
            self.last_frame_time = self.env.sim_time

    def after_step(self, obs: dict, reward: float, info: dict) -> None:
        self.lines = [self._part(), *outcome_text(reward, info)]
        if self.subgoal is None:
            self.camera_image = obs["rgb"]
            if self.step % JOINT_STEPS_PER_FRAME and "metrics" not in info:
                return
        self.frames.append(self.frame())

    def _part(self) -> str:
        return "joint velocities" if self.subgoal is None else f"{self.subgoal.part} subgoal"

    def frame(self) -> np.ndarray:
        camera = overhead_camera(self.env.robot.base_pose(), *self.size)
        image = Image.fromarray(render(self.env.world.client, camera))
        draw = ImageDraw.Draw(image, "RGBA")
        if self.subgoal is not None and self.subgoal.base_goal is not None:
            draw_base_goal(draw, camera, self.env.robot.base_pose(), self.subgoal.base_goal)
        if self.subgoal is not None and self.subgoal.arm_point is not None:
            draw_ring(draw, camera.project(self.subgoal.arm_point)[0], ARM_COLOUR)
        paste_camera_inset(image, self.camera_image, self.subgoal)
        steps = self.env.control.episode_steps
        draw_text_panel(draw, image.width, [f"step {self.step}/{steps}", *self.lines,
                                            f"return {self.env.episode_return:+.2f}"])
        return np.asarray(image)


def draw_arrow(draw: ImageDraw.ImageDraw, start, end, colour, width: int = 3, min_length: float = 0.0) -> None:
    """A line from ``start`` toward ``end`` (x, y), at least ``min_length`` long, with a filled head."""
    start, end = np.asarray(start, float), np.asarray(end, float)
    direction = end - start
    length = float(np.hypot(*direction))
    if length < 1e-6:
        return
    unit, normal = direction / length, np.array([-direction[1], direction[0]]) / length
    end = start + max(length, min_length) * unit
    draw.line([tuple(start), tuple(end)], fill=colour, width=width)
    head = min(12.0, 0.5 * max(length, min_length))
    corners = [end, end - head * unit + 0.5 * head * normal, end - head * unit - 0.5 * head * normal]
    draw.polygon([tuple(corner) for corner in corners], fill=colour)


def draw_base_goal(draw: ImageDraw.ImageDraw, camera: ViewCamera, robot_pose, goal: np.ndarray) -> None:
    """The base goal on the floor of the overhead view: a ring at its position, an arrow along
    its final heading, and a thin line to it from the robot."""
    x, y, yaw = goal
    tip = (x + HEADING_ARROW_M * np.cos(yaw), y + HEADING_ARROW_M * np.sin(yaw))
    robot, centre, head = camera.project(np.array([[robot_pose[0], robot_pose[1], 0.0], [x, y, 0.0], [*tip, 0.0]]))
    draw.line([tuple(robot), tuple(centre)], fill=GOAL_COLOUR[:3] + (140,), width=2)
    draw_ring(draw, centre, GOAL_COLOUR)
    draw_arrow(draw, centre, head, GOAL_COLOUR)


def draw_ring(draw: ImageDraw.ImageDraw, centre, colour, radius: float = 7.0) -> None:
    centre = np.asarray(centre, float)
    draw.ellipse([tuple(centre - radius), tuple(centre + radius)], outline=colour, width=3)


def paste_camera_inset(image: Image.Image, rgb: np.ndarray, subgoal: Subgoal | None) -> None:
    """The robot's camera image in the top-right corner, with an arm subgoal's pixel and push."""
    inset = Image.fromarray(rgb).resize((INSET_SIZE, INSET_SIZE), Image.NEAREST)
    draw = ImageDraw.Draw(inset, "RGBA")
    if subgoal is not None and subgoal.pixel is not None:
        scale = INSET_SIZE / rgb.shape[0]
        centre = (np.array(subgoal.pixel[::-1], float) + 0.5) * scale
        draw_ring(draw, centre, ARM_COLOUR, radius=6.0)
        if subgoal.push_end is not None:
            end = (np.array(subgoal.push_end[::-1], float) + 0.5) * scale
            draw_arrow(draw, centre, end, ARM_COLOUR, min_length=PUSH_ARROW_MIN_PX)
    left = image.width - INSET_SIZE - MARGIN
    ImageDraw.Draw(image).rectangle([left - 2, MARGIN - 2, left + INSET_SIZE + 1, MARGIN + INSET_SIZE + 1],
                                    outline=(255, 255, 255))
    image.paste(inset, (left, MARGIN))


def draw_text_panel(draw: ImageDraw.ImageDraw, image_width: int, lines: list[str]) -> None:
    """Lines of white text on a translucent panel in the top-left corner, each cut to fit
    beside the camera inset."""
    width = image_width - INSET_SIZE - 4 * MARGIN
    fitted = [_fit(line, width) for line in lines]
    height = sum(FONT.getbbox(line or " ")[3] + 4 for line in fitted)
    longest = max(FONT.getlength(line) for line in fitted)
    draw.rectangle([MARGIN, MARGIN, 3 * MARGIN + longest, 3 * MARGIN + height], fill=PANEL_COLOUR)
    top = 2 * MARGIN
    for line in fitted:
        draw.text((2 * MARGIN, top), line, font=FONT, fill=TEXT_COLOUR)
        top += FONT.getbbox(line or " ")[3] + 4


def _fit(line: str, width: float) -> str:
    if FONT.getlength(line) <= width:
        return line
    while line and FONT.getlength(line + "...") > width:
        line = line[:-1]
    return line + "..."
