"""Dense per-pixel Q maps for SGP-D (paper appendix A.2, facts sheet section 5).

Two convolutional branches, one over the RGB-D image (rgb / 255 and depth / 3 m, 4 channels)
and one over the local map (C channels / 255), each 4 conv layers with stride 2 (S -> S/16),
are concatenated on channels; 2 transposed convolutions with stride 2 bring them to S/4 = Q
with ``YAW_BINS + PUSH_BINS`` = 24 output maps: channels 0..11 are the L base maps (one per
yaw bin), channels 12..23 the K arm maps (one per push direction).

With ``skip`` (our addition, off by default) the head also sees the two branches' S/4
features, U-Net style: the second deconvolution keeps ``head_width`` channels, is concatenated
with the image and map features after their second conv (already at Q x Q), and two 1x1
convolutions give the maps (a 3x3 one made updates 1.8x slower than without the skip; the
1x1 pair, 1.2x). A 4 x 4 bottleneck at 64 px (S/16) has to place a 1-2 cell button from
16 x 16 px features; the skip gives each cell its own local features.

``QMapNetwork.forward`` flattens the maps in the environment's ``Discrete`` index order
(``relmogen/envs/subgoal_controls.py``): ``l * Q*Q + i * Q + j`` for base actions and
``L * Q*Q + k * Q*Q + i * Q + j`` for arm actions, i.e. ``maps.reshape(B, -1)`` of the
(B, L + K, Q, Q) tensor.

Observations may come channels-last as the environment emits them, or channels-first as
SB3's ``VecTransposeImage`` leaves them: it transposes every uint8 (H, W, C) box in [0, 255]
whatever C is, so ``rgb`` (C = 3) AND ``local_map`` (C = 1 or 2) arrive as (C, H, W) in
training. The layout is read from the observation space (channel axis = the smallest one,
SB3's own rule), so the network follows whatever space it was built with.
"""

from __future__ import annotations

import numpy as np
import torch as th
from gymnasium import spaces
from torch import nn

from relmogen.agents.networks import DEPTH_SCALE
from relmogen.envs.subgoal_controls import PUSH_BINS, Q_DOWNSAMPLE, YAW_BINS

NUM_MAPS = YAW_BINS + PUSH_BINS


def is_channels_first(space: spaces.Box) -> bool:
    """SB3's heuristic: the channel axis of an image box is its smallest dimension."""
    return int(np.argmin(space.shape)) == 0


def to_channels_first(tensor: th.Tensor, channels_first: bool) -> th.Tensor:
    """(B, H, W, C) -> (B, C, H, W) unless the tensor already is channels-first."""
    return tensor if channels_first else tensor.permute(0, 3, 1, 2)


def conv_branch(in_channels: int, widths: tuple[int, ...]) -> nn.Sequential:
    """len(widths) 3x3 convolutions with stride 2 and ReLU: (B, C, S, S) -> (B, widths[-1], S/2^n, S/2^n)."""
    layers: list[nn.Module] = []
    for width in widths:
        layers += [nn.Conv2d(in_channels, width, 3, stride=2, padding=1), nn.ReLU()]
        in_channels = width
    return nn.Sequential(*layers)


def deconv_head(in_channels: int, hidden: int, out_channels: int) -> nn.Sequential:
    """Two 4x4 transposed convolutions with stride 2 (x4 resolution); linear output."""
    return nn.Sequential(
        nn.ConvTranspose2d(in_channels, hidden, 4, stride=2, padding=1), nn.ReLU(),
        nn.ConvTranspose2d(hidden, out_channels, 4, stride=2, padding=1),
    )


SKIP_DEPTH = 4  # modules of a conv branch (2 convs + ReLUs) before its S/4 features


def skip_head(in_channels: int, skip_channels: int, hidden: int, out_channels: int) -> nn.ModuleDict:
    """Deconvolutions to Q x Q hidden features, then (with the skip features) two 1x1 convs to the maps."""
    return nn.ModuleDict({
        "up": nn.Sequential(nn.ConvTranspose2d(in_channels, hidden, 4, stride=2, padding=1), nn.ReLU(),
                            nn.ConvTranspose2d(hidden, hidden, 4, stride=2, padding=1), nn.ReLU()),
        "out": nn.Sequential(nn.Conv2d(hidden + skip_channels, hidden, 1), nn.ReLU(),
                             nn.Conv2d(hidden, out_channels, 1)),
    })


class QMapNetwork(nn.Module):
    """Observation dict -> Q values over all SGP-D actions, (B, (L + K) * Q * Q)."""

    def __init__(self, observation_space: spaces.Dict, widths: tuple[int, ...] = (32, 64, 64, 128),
                 head_width: int = 128, skip: bool = False):
        super().__init__()
        if len(widths) != 4:
            raise ValueError(f"QMapNetwork needs 4 conv widths (S -> S/16), got {widths}")
        rgb_space, map_space = observation_space["rgb"], observation_space["local_map"]
        self.rgb_channels_first = is_channels_first(rgb_space)
        self.map_channels_first = is_channels_first(map_space)
        self.image_size = rgb_space.shape[-1] if self.rgb_channels_first else rgb_space.shape[0]
        if self.image_size % 16:
            raise ValueError(f"QMapNetwork needs an image size divisible by 16, got {self.image_size}")
        self.q = self.image_size // Q_DOWNSAMPLE
        map_channels = map_space.shape[0] if self.map_channels_first else map_space.shape[-1]
        self.image_branch = conv_branch(4, widths)
        self.map_branch = conv_branch(map_channels, widths)
        self.skip = bool(skip)
        if self.skip:
            self.head = skip_head(2 * widths[-1], 2 * widths[1], head_width, NUM_MAPS)
        else:
            self.head = deconv_head(2 * widths[-1], head_width, NUM_MAPS)

    @property
    def n_actions(self) -> int:
        return NUM_MAPS * self.q * self.q

    def image_tensor(self, obs: dict[str, th.Tensor]) -> th.Tensor:
        """RGB in [0, 1] and depth / 3 m, channels-first: (B, 4, S, S)."""
        rgb = to_channels_first(obs["rgb"].float(), self.rgb_channels_first) / 255.0
        depth = obs["depth"].float()
        depth = depth.permute(0, 3, 1, 2) if depth.shape[-1] == 1 else depth
        return th.cat([rgb, depth / DEPTH_SCALE], dim=1)

    def map_tensor(self, obs: dict[str, th.Tensor]) -> th.Tensor:
        return to_channels_first(obs["local_map"].float(), self.map_channels_first) / 255.0

    def q_maps(self, obs: dict[str, th.Tensor]) -> th.Tensor:
        """(B, L + K, Q, Q): channels 0..L-1 base yaw bins, L..L+K-1 arm push directions."""
        image, local_map = self.image_tensor(obs), self.map_tensor(obs)
        if not self.skip:
            return self.head(th.cat([self.image_branch(image), self.map_branch(local_map)], dim=1))
        image_q = self.image_branch[:SKIP_DEPTH](image)
        map_q = self.map_branch[:SKIP_DEPTH](local_map)
        bottleneck = th.cat([self.image_branch[SKIP_DEPTH:](image_q), self.map_branch[SKIP_DEPTH:](map_q)], dim=1)
        return self.head["out"](th.cat([self.head["up"](bottleneck), image_q, map_q], dim=1))

    def forward(self, obs: dict[str, th.Tensor]) -> th.Tensor:
        maps = self.q_maps(obs)
        return maps.reshape(maps.shape[0], -1)
