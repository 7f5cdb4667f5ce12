"""Network branches for the subgoal policies and the joint-velocity baselines.

SGP-R encoder (paper appendix A.2, facts sheet section 5): RGB-D through 3 conv layers
(32 8x8/4, 64 4x4/2, 64 3x3/1), the LiDAR scan through 3 conv1d layers, the task vector
through 2 FC layers; each branch ends in FC + ReLU; the branch outputs are concatenated.
The same encoder serves SAC on joint velocities, so the baselines see the same inputs.
"""

from __future__ import annotations

import gymnasium as gym
import torch as th
from stable_baselines3.common.torch_layers import BaseFeaturesExtractor
from torch import nn

DEPTH_SCALE = 3.0  # metres: the camera's maximum range maps to 1.0


def _image_branch(in_channels: int, height: int, width: int, out_dim: int) -> tuple[nn.Module, nn.Module]:
    conv = nn.Sequential(
        nn.Conv2d(in_channels, 32, 8, stride=4), nn.ReLU(),
        nn.Conv2d(32, 64, 4, stride=2), nn.ReLU(),
        nn.Conv2d(64, 64, 3, stride=1), nn.ReLU(),
        nn.Flatten(),
    )
    with th.no_grad():
        flat = conv(th.zeros(1, in_channels, height, width)).shape[1]
    return conv, nn.Sequential(nn.Linear(flat, out_dim), nn.ReLU())


def _scan_branch(num_rays: int, out_dim: int) -> nn.Module:
    conv = nn.Sequential(
        nn.Conv1d(1, 32, 5, stride=2), nn.ReLU(),
        nn.Conv1d(32, 64, 3, stride=2), nn.ReLU(),
        nn.Conv1d(64, 64, 3, stride=2), nn.ReLU(),
        nn.Flatten(),
    )
    with th.no_grad():
        flat = conv(th.zeros(1, 1, num_rays)).shape[1]
    return nn.Sequential(conv, nn.Linear(flat, out_dim), nn.ReLU())


class SGPREncoder(BaseFeaturesExtractor):
    """Multi-branch encoder over ``rgb``, ``depth``, ``scan`` and ``task_obs``.

    Accepts the environment's own layout: ``rgb`` as uint8 values (H, W, 3) or transposed
    to (3, H, W) by SB3's ``VecTransposeImage``; ``depth`` as (H, W, 1) metres. Use it with
    ``normalize_images=False``: the encoder scales RGB and depth itself.
    """

    def __init__(self, observation_space: gym.spaces.Dict, image_dim: int = 256, scan_dim: int = 128,
                 task_dim: int = 128):
        rgb_shape = observation_space["rgb"].shape
        self.channels_first = rgb_shape[0] == 3
        height, width = (rgb_shape[1:] if self.channels_first else rgb_shape[:2])
        super().__init__(observation_space, features_dim=image_dim + scan_dim + task_dim)
        self.image_conv, self.image_fc = _image_branch(4, height, width, image_dim)
        self.scan = _scan_branch(observation_space["scan"].shape[0], scan_dim)
        task_in = observation_space["task_obs"].shape[0]
        self.task = nn.Sequential(nn.Linear(task_in, 128), nn.ReLU(), nn.Linear(128, 128), nn.ReLU(),
                                  nn.Linear(128, task_dim), nn.ReLU())

    def image_tensor(self, observations: dict[str, th.Tensor]) -> th.Tensor:
        """RGB in [0, 1] and depth / 3 m stacked channels-first: (B, 4, H, W)."""
        rgb = observations["rgb"].float()
        if not self.channels_first:
            rgb = rgb.permute(0, 3, 1, 2)
        rgb = rgb / 255.0
        depth = observations["depth"].float()
        depth = depth.permute(0, 3, 1, 2) if depth.shape[-1] == 1 else depth
        return th.cat([rgb, depth / DEPTH_SCALE], dim=1)

    def forward(self, observations: dict[str, th.Tensor]) -> th.Tensor:
        image = self.image_fc(self.image_conv(self.image_tensor(observations)))
        scan = self.scan(observations["scan"].float().unsqueeze(1))
        task = self.task(observations["task_obs"].float())
        return th.cat([image, scan, task], dim=1)
