"""A keypoint image branch for the SGP-R encoder (ours; ``algo.image_encoder: keypoints``).

The paper's branch flattens a 4 x 4 feature map from 64 px images, so where something is in the
image reaches the critic only through which flattened unit fires. An arm subgoal is a pixel, and
TabletopReachM's goal is a few-pixel marker that must be found in the image: the policy has to
turn "where the marker is" into "which pixel to choose". A spatial softmax (Levine, Finn et al.,
"End-to-End Training of Deep Visuomotor Policies", 2016; robomimic's visual encoder) turns each
feature channel into the expected (x, y) image position of its activation, so positions are
features the actor can map to pixel actions directly.

Branch: the paper's first convolution (32 8x8/4: 15 x 15 at 64 px), a 3x3 convolution to
``channels`` maps at the same resolution, a spatial softmax with a learned temperature, then
FC + ReLU as in the paper's branch.
"""

from __future__ import annotations

import torch as th
from torch import nn


class SpatialSoftmax(nn.Module):
    """(B, C, H, W) feature maps -> (B, 2C): each channel's softmax-weighted mean x and y, both
    in [-1, 1] (x along the width, y along the height)."""

    def __init__(self, height: int, width: int):
        super().__init__()
        ys, xs = th.meshgrid(th.linspace(-1.0, 1.0, height), th.linspace(-1.0, 1.0, width), indexing="ij")
        self.register_buffer("grid", th.stack([xs.reshape(-1), ys.reshape(-1)], dim=1))  # (HW, 2)
        self.log_temperature = nn.Parameter(th.zeros(()))

    def forward(self, features: th.Tensor) -> th.Tensor:
        batch, channels = features.shape[:2]
        flat = features.reshape(batch, channels, -1) / self.log_temperature.exp()
        attention = th.softmax(flat, dim=-1)  # (B, C, HW)
        return (attention @ self.grid).reshape(batch, 2 * channels)


def keypoint_image_branch(in_channels: int, height: int, width: int, out_dim: int,
                          channels: int = 32) -> tuple[nn.Module, nn.Module]:
    """``(conv, fc)`` with the interface of ``networks._image_branch``: ``fc(conv(images))``."""
    features = nn.Sequential(
        nn.Conv2d(in_channels, 32, 8, stride=4), nn.ReLU(),
        nn.Conv2d(32, channels, 3, padding=1),
    )
    with th.no_grad():
        _, _, map_height, map_width = features(th.zeros(1, in_channels, height, width)).shape
    conv = nn.Sequential(*features, SpatialSoftmax(map_height, map_width))
    return conv, nn.Sequential(nn.Linear(2 * channels, out_dim), nn.ReLU())
