"""ArrangeChairMM: tuck the chairs under the dining table, through the gaps between its legs.

Task Description:
    Chairs stand pulled out from the dining table of a house scene, one at each chosen gap
    between the table legs on the long sides. The robot must push every chair under the
    table: the seat (0.40 m wide) passes between legs 0.595 m apart and under the 0.71 m
    underside, the backrest stops at the table edge (tucked = backrest 2 cm from it). Nothing about the chairs or the table
    is in the observation: the policy must find them in the images.

Randomizations:
    Chairs: ``chairs_per_episode`` of the table's side gaps (random subset), each chair
    pulled out 0.3-0.5 m from its tucked pose along the gap normal, shifted up to 0.04 m
    sideways, yaw offset in [-0.15, 0.15] rad.
    Robot start: a free point of the dining room 1.2-3 m from the table centre, at least
    0.75 m from every chair, facing the table centre +-0.5 rad.

Success Conditions:
    Every chair's position (floor point under the seat centre) within 0.1 m of its tucked
    position. The episode ends on success.

Reward:
    tuck: 40 x the decrease of the summed chair-to-tucked distances (a potential: pulling a
    chair back out costs what pushing it in earned). No reward for approaching the chairs.

Metrics:
    success, closed_5 / closed_10 (chairs within 5 / 10 cm of tucked), chairs (how many),
    closed_10_fraction, tuck_distance (summed, metres, at the end).
"""

from __future__ import annotations

import numpy as np

from relmogen.scenes.objects.chair import CHAIR, Chair
from relmogen.tasks.base import Task, register_task
from relmogen.tasks.terms import PotentialReward

TUCK_CLEARANCE = 0.02  # backrest front face to the table edge when tucked, metres
TUCKED_DEPTH = -CHAIR.back_inner_x - TUCK_CLEARANCE  # seat centre inside the table edge


def unit(yaw: float) -> np.ndarray:
    return np.array([np.cos(yaw), np.sin(yaw)])


@register_task
class ArrangeChairMM(Task):
    name = "ArrangeChairMM"
    scene_kind = "house"
    head_tilt = "navigation"
    subgoal_steps = 25
    subgoal_parts = ("base", "arm")
    task_obs_dim = 33  # proprioception only: the chairs must be seen, not given
    chairs_per_episode = 3
    pull_range = (0.3, 0.5)
    lateral_range = 0.04
    yaw_range = 0.15
    loose_tolerance, tight_tolerance = 0.10, 0.05
    start_distance = (1.2, 3.0)
    start_chair_clearance = 0.75

    def __init__(self, ctx):
        super().__init__(ctx)
        self.chairs: list[Chair] = []
        self.tucked_xy = np.zeros((0, 2))
        self.tucked_yaw = np.zeros(0)
        self.gap_indices: list[int] = []
        self.reward_terms = [PotentialReward("tuck", self.total_tuck_distance, 40.0)]

    # ------------------------------------------------------------------ set-up
    def load(self) -> None:
        table = self.ctx.scene.table
        if table is None:
            raise ValueError(f"{self.name} needs a scene with a dining table, got {self.ctx.scene.name}")
        self.count = min(self.chairs_per_episode, len(table.side_gaps))
        self.chairs = [Chair(self.ctx.world.client) for _ in range(self.count)]
        self.gap_tucked = [self.tucked_pose(gap) for gap in table.side_gaps]

    @staticmethod
    def tucked_pose(gap) -> tuple[np.ndarray, float]:
        """Seat-centre xy and yaw of a chair fully tucked at ``gap`` (facing into the table)."""
        edge_xy, normal_yaw, _ = gap
        return np.asarray(edge_xy) - TUCKED_DEPTH * unit(normal_yaw), float(np.remainder(normal_yaw, 2 * np.pi) - np.pi)

    def object_bodies(self) -> list[int]:
        return [chair.body_id for chair in self.chairs]

    def reset(self, rng: np.random.Generator) -> None:
        gaps = self.ctx.scene.table.side_gaps
        self.gap_indices = sorted(rng.choice(len(gaps), self.count, replace=False).tolist())
        self.tucked_xy = np.array([self.gap_tucked[i][0] for i in self.gap_indices])
        self.tucked_yaw = np.array([self.gap_tucked[i][1] for i in self.gap_indices])
        starts = [self._place_chair(chair, i, rng) for chair, i in zip(self.chairs, self.gap_indices)]
        self.ctx.robot.reset(self._sample_robot_start(rng, np.array(starts)), head_tilt=self.head_tilt_angle())

    def _place_chair(self, chair: Chair, gap_index: int, rng: np.random.Generator) -> np.ndarray:
        _, normal_yaw, _ = self.ctx.scene.table.side_gaps[gap_index]
        tucked_xy, tucked_yaw = self.gap_tucked[gap_index]
        xy = (tucked_xy + rng.uniform(*self.pull_range) * unit(normal_yaw)
              + rng.uniform(-self.lateral_range, self.lateral_range) * unit(normal_yaw + 0.5 * np.pi))
        chair.set_pose(xy, tucked_yaw + rng.uniform(-self.yaw_range, self.yaw_range))
        return xy

    def _sample_robot_start(self, rng: np.random.Generator, chair_xy: np.ndarray) -> tuple[float, float, float]:
        scene, centre = self.ctx.scene, np.asarray(self.ctx.scene.table.center)
        for _ in range(200):
            xy = self.sample_free_point(rng, "dining")
            near_chairs = np.min(np.linalg.norm(chair_xy - xy, axis=1)) < self.start_chair_clearance
            if near_chairs or not self.start_distance[0] <= np.linalg.norm(xy - centre) <= self.start_distance[1]:
                continue
            to_table = centre - xy
            yaw = float(np.arctan2(to_table[1], to_table[0]) + rng.uniform(-0.5, 0.5))
            return float(xy[0]), float(xy[1]), yaw
        raise RuntimeError(f"no robot start in the dining room of {scene.name} clear of the chairs")

    # ------------------------------------------------------------------ state
    def chair_xy(self) -> np.ndarray:
        return np.array([chair.position()[:2] for chair in self.chairs])

    def tuck_distances(self) -> np.ndarray:
        """Per chair: horizontal distance from its tucked position, metres."""
        return np.linalg.norm(self.chair_xy() - self.tucked_xy, axis=1)

    def total_tuck_distance(self) -> float:
        return float(self.tuck_distances().sum())

    def is_success(self) -> bool:
        return bool(np.all(self.tuck_distances() < self.loose_tolerance))

    def task_obs(self) -> np.ndarray:
        return self.proprioception()

    def metrics(self) -> dict[str, float]:
        distances = self.tuck_distances()
        closed_10 = float(np.sum(distances < self.loose_tolerance))
        return {
            "success": float(self.is_success()),
            "closed_5": float(np.sum(distances < self.tight_tolerance)),
            "closed_10": closed_10,
            "chairs": float(len(distances)),
            "closed_10_fraction": closed_10 / max(len(distances), 1),
            "tuck_distance": float(distances.sum()),
        }
