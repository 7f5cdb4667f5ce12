"""Dense per-pixel Q maps for SGP-D (paper appendix A.2, facts sheet section 5).

Two convolutional branches, one over the RGB-D image (rgb / 255 and depth / 3 m, 4 channels)
and one over the local map (C channels / 255), each 4 conv layers with stride 2 (S -> S/16),
are concatenated on channels; transposed convolutions with stride 2 bring them to Q with
``YAW_BINS + PUSH_BINS`` = 24 output maps: channels 0..11 are the L base maps (one per yaw bin),
channels 12..23 the K arm maps (one per push direction). The paper's Q = S/4 takes 2 of them;
a finer map (``q``, e.g. the paper's 32 x 32 from 64 px inputs) takes one more per doubling.

With ``skip`` (our addition, off by default) the head also sees the two branches' Q x Q
features, U-Net style: the last deconvolution keeps ``head_width`` channels, is concatenated
with the image and map features after the conv that brings them to Q x Q, and two 1x1
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

With ``unet`` (ours, off by default; not with ``skip``) the head is a U-Net decoder: each
upsampling stage (a 4x4 transposed convolution with stride 2) is concatenated with both
branches' features at its resolution and fused by a 1x1 convolution, down to Q x Q, then a 1x1
convolution gives the maps. With ``skip`` a cell sees the bottleneck (4 x 4 at 64 px, 16 px a
cell) and one conv layer over its own 3 x 3 pixels; in ArrangeKitchenMM such a network's greedy
push was the same cell and bin in all of 16 oracle states (results/sgpd-explore, tenth
session): values of places, not of what is there. The U-Net gives each cell features at every
scale between, for the same update cost (0.81 against 0.79 CPU s). Measured on one seed: its
training episodes closed more items early (0.52-0.65 against 0.28-0.37 per episode in
episodes 101-300), but at episode 520 its greedy push too was one cell and bin in all 16 states.

The convolutions run channels-last (weights and inputs; oneDNN's faster kernels on CPU, and
cuDNN's NHWC ones on a GPU): the same Q values as the NCHW layout, for 1.1-1.3x cheaper updates
on the AMD EPYC host (``relmogen bench train``, ``qmap_variants``).

``head_kernel`` (ours; default 4, the paper's) is the kernel of the head's last upsampling: with
2 each Q x Q cell comes from one feature pixel below it instead of a 4 x 4 neighbourhood, a
quarter of that layer's arithmetic, which is the network's largest at 32 x 32.

With ``bf16`` (ours, off by default) every layer but the last runs under bfloat16 autocast;
the last layer and the Q values stay float32, so actions whose values differ by less than
bfloat16's step (about 0.03 at Q = 5) are still told apart. Weights, gradients and the
optimiser stay float32. On a CPU with AMX or AVX512-BF16 an update costs about half as much
(``relmogen bench train``, ``qmap_precisions``); elsewhere it may cost more.
"""

from __future__ import annotations

import contextlib

import numpy as np
import torch as th
from gymnasium import spaces
from torch import nn

from relmogen.agents.networks import DEPTH_SCALE
from relmogen.envs.subgoal_controls import PUSH_BINS, Q_DOWNSAMPLE, YAW_BINS

NUM_MAPS = YAW_BINS + PUSH_BINS
HEAD_KERNELS = (4, 2)  # the last upsampling's kernel: the paper's 4x4, or 2x2 (ours)


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


def upsampling_layer(in_channels: int, out_channels: int, kernel: int = 4) -> nn.ConvTranspose2d:
    """x 2 resolution: the paper's 4x4 transposed convolution, or a 2x2 one (each input pixel
    spreads over its own 2 x 2 output block: a quarter of the arithmetic)."""
    if kernel not in HEAD_KERNELS:
        raise ValueError(f"the Q-map head's last kernel must be one of {HEAD_KERNELS}, got {kernel}")
    return nn.ConvTranspose2d(in_channels, out_channels, kernel, stride=2, padding=(kernel - 2) // 2)


def upsampling(in_channels: int, hidden: int, out_channels: int, stages: int, relu_last: bool,
               last_kernel: int = 4) -> list[nn.Module]:
    """``stages`` transposed convolutions with stride 2 (x 2^stages resolution): 4x4, the last
    one ``last_kernel`` x ``last_kernel``."""
    layers: list[nn.Module] = []
    for stage in range(stages):
        last = stage == stages - 1
        layers.append(upsampling_layer(in_channels, out_channels if last else hidden, last_kernel if last else 4))
        if not last or relu_last:
            layers.append(nn.ReLU())
        in_channels = hidden
    return layers


def deconv_head(in_channels: int, hidden: int, out_channels: int, stages: int = 2,
                last_kernel: int = 4) -> nn.Sequential:
    """``stages`` transposed convolutions (the paper's 2: S/16 -> S/4); linear output."""
    return nn.Sequential(*upsampling(in_channels, hidden, out_channels, stages, relu_last=False,
                                     last_kernel=last_kernel))


def skip_head(in_channels: int, skip_channels: int, hidden: int, out_channels: int, stages: int = 2,
              last_kernel: int = 4) -> nn.ModuleDict:
    """Deconvolutions to Q x Q hidden features, then (with the skip features) two 1x1 convs to the maps."""
    return nn.ModuleDict({
        "up": nn.Sequential(*upsampling(in_channels, hidden, hidden, stages, relu_last=True, last_kernel=last_kernel)),
        "out": nn.Sequential(nn.Conv2d(hidden + skip_channels, hidden, 1), nn.ReLU(),
                             nn.Conv2d(hidden, out_channels, 1)),
    })


def unet_head(bottleneck_channels: int, skip_channels: list[int], hidden: int, out_channels: int,
              last_kernel: int = 4) -> nn.ModuleDict:
    """One stage per entry of ``skip_channels`` (coarse to fine): upsample x2, concatenate those
    skip features, fuse by a 1x1 conv; then a 1x1 conv to the maps."""
    up, fuse, in_channels = nn.ModuleList(), nn.ModuleList(), bottleneck_channels
    for stage, channels in enumerate(skip_channels):
        kernel = last_kernel if stage == len(skip_channels) - 1 else 4
        up.append(nn.Sequential(upsampling_layer(in_channels, hidden, kernel), nn.ReLU()))
        fuse.append(nn.Sequential(nn.Conv2d(hidden + channels, hidden, 1), nn.ReLU()))
        in_channels = hidden
    return nn.ModuleDict({"up": up, "fuse": fuse, "out": nn.Conv2d(hidden, out_channels, 1)})


def branch_features(branch: nn.Sequential, x: th.Tensor) -> list[th.Tensor]:
    """Outputs of each stride-2 conv (after its ReLU), finest first."""
    features = []
    for conv, relu in zip(branch[::2], branch[1::2]):
        x = relu(conv(x))
        features.append(x)
    return features


def downsampling_convs(image_size: int, q: int) -> int:
    """How many of the 4 stride-2 convs bring the image to Q x Q (2 for the paper's Q = S/4)."""
    ratio = image_size // q
    if q < 1 or image_size % q or ratio & (ratio - 1) or not 2 <= ratio <= 8:
        raise ValueError(f"Q maps of {q} x {q} need an image size of 2, 4 or 8 times that, got {image_size}")
    return ratio.bit_length() - 1


class QMapNetwork(nn.Module):
    """Observation dict -> Q values over all SGP-D actions, (B, (L + K) * Q * Q)."""

    def __init__(self, observation_space: spaces.Dict, widths: tuple[int, ...] = (32, 64, 64, 128),
                 head_width: int = 128, skip: bool = False, q: int | None = None, bf16: bool = False,
                 unet: bool = False, head_kernel: int = 4):
        super().__init__()
        self.bf16 = bool(bf16)
        if skip and unet:
            raise ValueError("choose one Q-map head: skip or unet")
        if len(widths) != 4:
            raise ValueError(f"QMapNetwork needs 4 conv widths (S -> S/16), got {widths}")
        rgb_space, map_space = observation_space["rgb"], observation_space["local_map"]
        self.rgb_channels_first = is_channels_first(rgb_space)
        self.map_channels_first = is_channels_first(map_space)
        self.image_size = rgb_space.shape[-1] if self.rgb_channels_first else rgb_space.shape[0]
        if self.image_size % 16:
            raise ValueError(f"QMapNetwork needs an image size divisible by 16, got {self.image_size}")
        self.q = self.image_size // Q_DOWNSAMPLE if q is None else int(q)
        convs_to_q = downsampling_convs(self.image_size, self.q)
        self.skip_depth = 2 * convs_to_q  # modules (conv + ReLU each) of a branch before its Q x Q features
        map_channels = map_space.shape[0] if self.map_channels_first else map_space.shape[-1]
        self.image_branch = conv_branch(4, widths)
        self.map_branch = conv_branch(map_channels, widths)
        self.skip, self.unet = bool(skip), bool(unet)
        stages = len(widths) - convs_to_q
        if self.unet:  # skips at S/8 ... Q, coarse to fine
            self.unet_skips = list(range(len(widths) - 2, convs_to_q - 2, -1))
            self.head = unet_head(2 * widths[-1], [2 * widths[i] for i in self.unet_skips], head_width, NUM_MAPS,
                                  head_kernel)
        elif self.skip:
            self.head = skip_head(2 * widths[-1], 2 * widths[convs_to_q - 1], head_width, NUM_MAPS, stages,
                                  head_kernel)
        else:
            self.head = deconv_head(2 * widths[-1], head_width, NUM_MAPS, stages, head_kernel)
        self.to(memory_format=th.channels_last)

    @property
    def n_actions(self) -> int:
        return NUM_MAPS * self.q * self.q

    def image_tensor(self, obs: dict[str, th.Tensor]) -> th.Tensor:
        """RGB in [0, 1] and depth / 3 m, channels-first: (B, 4, S, S)."""
        rgb = to_channels_first(obs["rgb"].float(), self.rgb_channels_first) / 255.0
        depth = obs["depth"].float()
        depth = depth.permute(0, 3, 1, 2) if depth.shape[-1] == 1 else depth
        return th.cat([rgb, depth / DEPTH_SCALE], dim=1).contiguous(memory_format=th.channels_last)

    def map_tensor(self, obs: dict[str, th.Tensor]) -> th.Tensor:
        local_map = to_channels_first(obs["local_map"].float(), self.map_channels_first) / 255.0
        return local_map.contiguous(memory_format=th.channels_last)

    def q_maps(self, obs: dict[str, th.Tensor]) -> th.Tensor:
        """(B, L + K, Q, Q): channels 0..L-1 base yaw bins, L..L+K-1 arm push directions."""
        with self.reduced_precision(obs["depth"].device):
            features = self.last_layer_input(obs)
        return self.last_layer(features.float())

    @property
    def last_layer(self) -> nn.Module:
        if self.unet:
            return self.head["out"]
        return self.head["out"][-1] if self.skip else self.head[-1]

    def reduced_precision(self, device: th.device):
        """bfloat16 autocast with ``bf16``, else nothing."""
        if not self.bf16:
            return contextlib.nullcontext()
        return th.autocast(device_type=device.type, dtype=th.bfloat16)

    def last_layer_input(self, obs: dict[str, th.Tensor]) -> th.Tensor:
        image, local_map = self.image_tensor(obs), self.map_tensor(obs)
        if self.unet:
            return self.unet_features(image, local_map)
        if not self.skip:
            return self.head[:-1](th.cat([self.image_branch(image), self.map_branch(local_map)], dim=1))
        depth = self.skip_depth
        image_q, map_q = self.image_branch[:depth](image), self.map_branch[:depth](local_map)
        bottleneck = th.cat([self.image_branch[depth:](image_q), self.map_branch[depth:](map_q)], dim=1)
        return self.head["out"][:-1](th.cat([self.head["up"](bottleneck), image_q, map_q], dim=1))

    def unet_features(self, image: th.Tensor, local_map: th.Tensor) -> th.Tensor:
        scales = [th.cat(pair, dim=1) for pair in zip(branch_features(self.image_branch, image),
                                                       branch_features(self.map_branch, local_map))]
        x = scales[-1]
        for up, fuse, index in zip(self.head["up"], self.head["fuse"], self.unet_skips):
            x = fuse(th.cat([up(x), scales[index]], dim=1))
        return x

    def forward(self, obs: dict[str, th.Tensor]) -> th.Tensor:
        maps = self.q_maps(obs)
        return maps.reshape(maps.shape[0], -1)
