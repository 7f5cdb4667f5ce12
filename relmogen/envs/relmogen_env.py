"""The Gymnasium environment: one task, one robot, one scene, one control.

``gymnasium.make("relmogen/PointNav-v0", control="joint")`` builds the world once; episodes
re-randomise poses in place. The control decides what one ``step`` means: 0.1 s of joint
velocities (``joint``) or one executed subgoal (``subgoal-r``, ``subgoal-d``).

Observation (a ``Dict`` that Stable-Baselines3's ``MultiInputPolicy`` accepts as is):
    rgb       (H, W, 3) uint8 head-camera colour image
    depth     (H, W, 1) float32 metres along the optical axis, 0.0 = no return
              (nearer than 0.35 m or farther than 3.0 m)
    scan      (220,)    float32 LiDAR ranges divided by the maximum range (1.0 = no hit)
    task_obs  (D,)      float32 task vector (55-D for navigation tasks), robot frame

With ``obs_mode="state"`` (ManiSkill's name; for debugging and for users who bring their own
perception) the sensors are replaced by one low-dimensional vector:
    state     (4 + D + O,) float32 base pose (x, y, cos yaw, sin yaw; world frame), the task
              vector above (goal, waypoints, proprioception), then each task object's position
              (robot frame), relative yaw as (cos, sin) and joint positions (``Task.object_state``)
The control's own keys (``local_map`` of ``subgoal-d``, ``last_subgoal``) are kept in both modes.

``env.spec.max_episode_steps`` (after ``gymnasium.make``) is the episode length of the control
made: 25 subgoals (5 for TabletopReachM), 750 joint steps, or ``episode_steps``.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from gymnasium.envs.registration import EnvSpec

from relmogen.envs.control_registry import make_control
from relmogen.robots.robot import Robot
from relmogen.robots.spec import load_spec
from relmogen.scenes import available_scenes, make_scene
from relmogen.simulation.contacts import robot_collisions
from relmogen.simulation.sensors import Camera, Lidar
from relmogen.simulation.world import World
from relmogen.tasks import TaskContext, task_class

CONTROL_DT = 0.1  # seconds per joint-velocity action (paper Section IV-B)
THIRD_PERSON_SIZE = (320, 240)
VIEW_KEYS = ("rgb", "local_map")
OBS_MODES = ("rgbd", "state")  # rgbd: camera, LiDAR and task vector (the paper's); state: low-dimensional
ROBOT_POSE_DIM = 4  # x, y, cos yaw, sin yaw


def view_unchanged(before: dict, after: dict) -> bool:
    """True when a step left the colour image and the local map (where present) exactly as they
    were: what a subgoal that found no plan, or pushed and moved nothing, leaves behind. Depth and
    the task vector are not compared: after an executed push the arm's return leaves a few
    depth pixels and the joint readings a hair different."""
    return all(np.array_equal(before[key], after[key]) for key in VIEW_KEYS if key in before)


class RelmogenEnv(gym.Env):
    metadata = {"render_modes": ["rgb_array"], "render_fps": 10}
    _spec: EnvSpec | None = None

    def __init__(
        self,
        task: str = "PointNav",
        control: str = "joint",
        robot: str = "fetch",
        scene: str | None = None,
        image_size: int = 128,
        render_mode: str | None = None,
        scene_seed: int = 0,
        episode_steps: int | None = None,
        obs_mode: str = "rgbd",
        **control_options: Any,
    ):
        task_cls = task_class(task)
        if obs_mode not in OBS_MODES:
            raise ValueError(f"unknown obs_mode {obs_mode!r}; valid: {', '.join(OBS_MODES)}")
        self.obs_mode = obs_mode
        if render_mode not in (None, "rgb_array"):
            raise ValueError(f"unknown render_mode {render_mode!r}; valid: None, 'rgb_array'")
        if int(image_size) < 16:
            raise ValueError(f"image_size must be at least 16 pixels, got {image_size}")
        scene = scene or f"{task_cls.scene_kind}_A"
        if not scene.startswith(task_cls.scene_kind):
            valid = [s for s in available_scenes() if s.startswith(task_cls.scene_kind)]
            raise ValueError(f"task {task} needs a {task_cls.scene_kind} scene; valid: {', '.join(valid)}")
        self.render_mode = render_mode
        self.world = World()
        self.scene = make_scene(scene, self.world.client, seed=scene_seed)
        self.robot = Robot(self.world.client, load_spec(robot))
        self.task = task_cls(TaskContext(self.world, self.scene, self.robot))
        self.task.load()
        self.camera = Camera(self.world.client, image_size, image_size, fov_deg=90.0)
        lidar = self.robot.spec.lidar
        self.lidar = Lidar(self.world.client, lidar.num_rays, lidar.fov_deg, lidar.max_range, lidar.min_range)
        self.control_steps_per_action = int(round(CONTROL_DT / self.world.time_step))
        self._collision_args = self._collision_filter()
        self.control = make_control(control, self, **control_options)
        if episode_steps is not None:  # shorter episodes for smoke tests; the paper's lengths by default
            if int(episode_steps) < 1:
                raise ValueError(f"episode_steps must be positive, got {episode_steps}")
            self.control.episode_steps = int(episode_steps)
        self.action_space = self.control.action_space
        self.observation_space = self._observation_space(image_size)
        self.elapsed_steps = 0
        self.sim_time = 0.0
        self.last_frame = None
        self.last_scan: np.ndarray | None = None  # raw ranges of the last observation
        self._last_scan_pose: np.ndarray | None = None
        self.frame_hook = None  # called during subgoal execution (videos of the motion)

    # ------------------------------------------------------------------ gymnasium API
    @property
    def spec(self) -> EnvSpec | None:
        """The spec ``gymnasium.make`` gave, with ``max_episode_steps`` filled in from the control
        made: an id's registration cannot hold it, as the control is a keyword of ``make``."""
        if self._spec is None or self._spec.max_episode_steps is not None or not hasattr(self, "control"):
            return self._spec
        return dataclasses.replace(self._spec, max_episode_steps=self.control.episode_steps)

    @spec.setter
    def spec(self, spec: EnvSpec | None) -> None:
        self._spec = spec

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        self.task.reset(self.np_random)
        self.task.after_reset()
        self.control.reset()
        self.elapsed_steps, self.sim_time, self.episode_return = 0, 0.0, 0.0
        return self._observe(), self.control.extra_info()

    def step(self, action):
        outcome = self.control.step(action)
        self.elapsed_steps += 1
        self.episode_return += outcome.reward
        terminated = outcome.termination is not None
        truncated = not terminated and self.elapsed_steps >= self.control.episode_steps
        info = dict(outcome.info, termination=outcome.termination, reward_terms=outcome.reward_terms)
        if terminated or truncated:
            metrics = self.task.metrics()
            info.update(metrics=metrics, is_success=bool(metrics["success"]))
        obs = self._observe()
        info.update(self.control.extra_info())
        return obs, outcome.reward, terminated, truncated, info

    def render(self):
        if self.render_mode != "rgb_array":
            return None
        return self.third_person_image()

    def close(self):
        if getattr(self, "world", None) is not None:
            self.world.close()
            self.world = None

    # ---------------------------------------------------------------- low-level pieces
    def simulate_control_step(self) -> tuple[float, dict[str, float], str | None]:
        """Advance 0.1 s with whatever motor commands are set; returns the task reward, its
        terms, and a termination cause ('success' or 'collision') or None. Collisions are
        checked after every physics step, so the episode ends at the first touch."""
        for _ in range(self.control_steps_per_action):
            self.world.step()
            if self.collisions():
                break
        self.sim_time += CONTROL_DT
        self.task.after_control_step()
        reward, terms = self.task.reward()
        return reward, terms, self.termination_cause()

    def termination_cause(self) -> str | None:
        if self.task.terminates_on_success() and self.task.is_success():
            return "success"
        if self.collisions():
            return "collision"
        return None

    def collisions(self):
        return robot_collisions(self.world.client, self.robot.robot_id, **self._collision_args)

    def third_person_image(self) -> np.ndarray:
        from relmogen.simulation.views import third_person_view

        return third_person_view(self.world.client, self.robot.base_pose(), *THIRD_PERSON_SIZE)

    # ------------------------------------------------------------------- observations
    def _observe(self) -> dict[str, np.ndarray]:
        position, rotation = self.robot.camera_pose()
        frame = self.camera.capture(position, rotation)
        self.last_frame = frame
        self.last_scan, self._last_scan_pose = self.scan(), np.asarray(self.robot.base_pose(), dtype=np.float64)
        scan = self.last_scan / np.float32(self.lidar.max_range)
        task_obs = self.task.task_obs()
        if not (np.isfinite(task_obs).all() and np.isfinite(scan).all()):
            raise RuntimeError(f"non-finite observation in {self.task.name}: task_obs={task_obs}, "
                               f"robot pose={self.robot.base_pose()}; the physics state is broken")
        if self.obs_mode == "state":
            obs = {"state": self._state_vector(task_obs)}
        else:
            obs = {"rgb": frame.rgb, "depth": frame.depth[..., None], "scan": scan, "task_obs": task_obs}
        obs.update(self.control.extra_observation())
        return obs

    def _state_vector(self, task_obs: np.ndarray) -> np.ndarray:
        x, y, yaw = self.robot.base_pose()
        pose = np.array([x, y, np.cos(yaw), np.sin(yaw)], dtype=np.float32)
        return np.concatenate([pose, task_obs, self.task.object_state()]).astype(np.float32)

    def observed_scan(self) -> np.ndarray:
        """The last observation's scan while the robot stands where it was taken (the paper plans
        on the most recent scan; this saves a ray cast per base subgoal), else a fresh one."""
        if self._last_scan_pose is not None and np.allclose(self.robot.base_pose(), self._last_scan_pose,
                                                            rtol=0.0, atol=1e-9):
            return self.last_scan
        return self.scan()

    def scan(self) -> np.ndarray:
        position, _ = self.robot.lidar_pose()
        return self.lidar.scan(np.asarray(position), self.robot.base_pose()[2])

    def _observation_space(self, size: int) -> spaces.Dict:
        if self.obs_mode == "state":
            dim = ROBOT_POSE_DIM + self.task.task_obs_dim + len(self.task.object_state())
            obs = {"state": spaces.Box(-np.inf, np.inf, (dim,), np.float32)}
        else:
            obs = {
                "rgb": spaces.Box(0, 255, (size, size, 3), np.uint8),
                "depth": spaces.Box(0.0, self.camera.max_depth, (size, size, 1), np.float32),
                "scan": spaces.Box(0.0, 1.0, (self.lidar.num_rays,), np.float32),
                "task_obs": spaces.Box(-np.inf, np.inf, (self.task.task_obs_dim,), np.float32),
            }
        obs.update(self.control.extra_observation_space())
        return spaces.Dict(obs)

    def _collision_filter(self) -> dict:
        robot = self.robot
        return dict(
            link_names=robot.link_names,
            allowed_links=frozenset(robot.gripper_link_indices),
            floor_contact_links=frozenset(robot.floor_contact_link_indices),
            floor_body=self.scene.floor_body_id,
        )
