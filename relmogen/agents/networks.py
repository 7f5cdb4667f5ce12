"""Network branches for the subgoal policies and the joint-velocity baselines.

SGP-R encoder (paper appendix A.2, facts sheet section 5): RGB-D through 3 conv layers
(32 8x8/4, 64 4x4/2, 64 3x3/1), the LiDAR scan through 3 conv1d layers, the task vector
through 2 FC layers; each branch ends in FC + ReLU; the branch outputs are concatenated.
The same encoder serves SAC on joint velocities, so the baselines see the same inputs.

Two additions of ours, both measured (results/table1/*/COMMANDS.md):

* the LiDAR scan and the task vector are standardised per entry with statistics fitted once,
  on the replay at the start of learning (``fit_input_scaling``), and kept in the weights: the
  raw goal is in metres (std about 4 m), the scan averages 0.1, and most arm entries are
  constant while a subgoal policy trains (the arm is tucked after every subgoal);
* ``image_shift`` > 0 applies DrQ's random shift (pad by n pixels, crop back at a random
  offset, per sample) to the images while ``augmenting`` is set, which SAC does for its
  gradient steps only.

``image_encoder="keypoints"`` swaps the image branch for ``agents/keypoints.py``'s (an option).
"""

from __future__ import annotations

import gymnasium as gym
import torch as th
from stable_baselines3.common.torch_layers import BaseFeaturesExtractor
from torch import nn
from torch.nn import functional as F

from relmogen.agents.keypoints import keypoint_image_branch

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


IMAGE_BRANCHES = {"paper": _image_branch, "keypoints": keypoint_image_branch}


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
                 task_dim: int = 128, image_shift: int = 0, image_encoder: str = "paper"):
        rgb_shape = observation_space["rgb"].shape
        self.channels_first = rgb_shape[0] == 3
        height, width = (rgb_shape[1:] if self.channels_first else rgb_shape[:2])
        super().__init__(observation_space, features_dim=image_dim + scan_dim + task_dim)
        if image_encoder not in IMAGE_BRANCHES:
            raise ValueError(f"image_encoder must be one of {sorted(IMAGE_BRANCHES)}, got {image_encoder!r}")
        self.image_conv, self.image_fc = IMAGE_BRANCHES[image_encoder](4, height, width, image_dim)
        # channels-last convolutions (oneDNN on CPU): updates 64 -> 60 ms of CPU at 64 px, batch 64
        self.image_conv.to(memory_format=th.channels_last)
        self.scan = _scan_branch(observation_space["scan"].shape[0], scan_dim)
        # SGP-R's optional ``last_subgoal`` (the previous action and its no-op flag) joins the task vector
        self.task_keys = [key for key in ("task_obs", "last_subgoal") if key in observation_space.spaces]
        task_in = sum(observation_space[key].shape[0] for key in self.task_keys)
        self.task = nn.Sequential(nn.Linear(task_in, 128), nn.ReLU(), nn.Linear(128, 128), nn.ReLU(),
                                  nn.Linear(128, task_dim), nn.ReLU())
        self.image_shift, self.augmenting = int(image_shift), False
        self.scan_scaling = InputScaling(observation_space["scan"].shape[0])
        self.task_scaling = InputScaling(task_in)

    def fit_input_scaling(self, observations: dict[str, th.Tensor]) -> None:
        """Standardise ``scan`` and ``task_obs`` with the statistics of this batch from now on."""
        self.scan_scaling.fit(observations["scan"].float())
        self.task_scaling.fit(self.task_vector(observations))

    @property
    def input_scaling_fitted(self) -> bool:
        return bool(self.task_scaling.fitted)

    def task_vector(self, observations: dict[str, th.Tensor]) -> th.Tensor:
        return th.cat([observations[key].float() for key in self.task_keys], dim=1)

    def image_tensor(self, observations: dict[str, th.Tensor]) -> th.Tensor:
        """RGB in [0, 1] and depth / 3 m as a (B, 4, H, W) view of a channels-last tensor: the
        channels are concatenated last, so the convolutions' layout costs no second copy (the
        channels-first cat plus a channels-last copy took 5-10x longer at batch 64). RGB may come
        as uint8 (the replay) or float (SB3's ``preprocess_obs``); the input is never modified."""
        rgb = observations["rgb"]
        rgb = rgb.permute(0, 2, 3, 1) if self.channels_first else rgb
        depth = observations["depth"].float()
        depth = depth.permute(0, 2, 3, 1) if depth.shape[-1] != 1 else depth
        rgb = rgb.to(th.float32, copy=True).mul_(1.0 / 255.0)
        return th.cat([rgb, depth / DEPTH_SCALE], dim=3).permute(0, 3, 1, 2)

    def prepare(self, observations: dict[str, th.Tensor]) -> "EncoderInputs":
        """The parameter-free part of ``forward`` (image tensor, float scan, task vector): SAC's
        gradient step prepares each observation batch once and feeds it to both the encoder and
        its target copy (issue 58), straight from the replay's uint8 images."""
        if isinstance(observations, EncoderInputs):
            return observations
        return EncoderInputs(images=self.image_tensor(observations), scan=observations["scan"].float(),
                             task=self.task_vector(observations))

    def forward(self, observations: dict[str, th.Tensor]) -> th.Tensor:
        inputs = self.prepare(observations)
        images = inputs["images"]
        if self.augmenting and self.image_shift:
            images = random_shift(images, self.image_shift)
        image = self.image_fc(self.image_conv(images.contiguous(memory_format=th.channels_last)))
        scan = self.scan(self.scan_scaling(inputs["scan"]).unsqueeze(1))
        task = self.task(self.task_scaling(inputs["task"]))
        return th.cat([image, scan, task], dim=1)


class EncoderInputs(dict):
    """``SGPREncoder.prepare``'s output: ``images`` (B, 4, H, W) channels-last floats, ``scan`` and
    ``task`` float vectors. Read-only for the encoders, so one batch can feed several of them."""


class InputScaling(nn.Module):
    """``(x - mean) / std`` per entry once fitted (identity before); constant entries (std below
    1e-3) are only centred. Mean, std and the fitted flag are buffers: saved with the weights."""

    def __init__(self, size: int):
        super().__init__()
        self.register_buffer("mean", th.zeros(size))
        self.register_buffer("std", th.ones(size))
        self.register_buffer("fitted", th.zeros((), dtype=th.bool))

    def fit(self, values: th.Tensor) -> None:
        std = values.std(dim=0)
        self.mean.copy_(values.mean(dim=0))
        self.std.copy_(th.where(std < 1e-3, th.ones_like(std), std))
        self.fitted.fill_(True)

    def forward(self, values: th.Tensor) -> th.Tensor:
        return (values - self.mean) / self.std

    def _load_from_state_dict(self, state_dict, prefix, *args, **kwargs):
        """Weights saved before the scaling existed load as the identity, marked fitted: the
        network was trained on raw inputs, so it must never be refitted."""
        if prefix + "mean" not in state_dict:
            state_dict.update({prefix + "mean": th.zeros_like(self.mean), prefix + "std": th.ones_like(self.std),
                               prefix + "fitted": th.ones((), dtype=th.bool)})
        super()._load_from_state_dict(state_dict, prefix, *args, **kwargs)


def random_shift(images: th.Tensor, pad: int) -> th.Tensor:
    """DrQ's augmentation: each image padded by ``pad`` pixels (edge values) and cropped back to
    its size at an independent random integer offset."""
    batch, _, height, width = images.shape
    padded = F.pad(images, (pad, pad, pad, pad), mode="replicate")
    offsets = th.randint(0, 2 * pad + 1, (batch, 2), device=images.device)
    rows = offsets[:, 0, None] + th.arange(height, device=images.device)  # (B, H)
    cols = offsets[:, 1, None] + th.arange(width, device=images.device)  # (B, W)
    index = th.arange(batch, device=images.device)[:, None, None]
    return padded.permute(0, 2, 3, 1)[index, rows[:, :, None], cols[:, None, :]].permute(0, 3, 1, 2)
