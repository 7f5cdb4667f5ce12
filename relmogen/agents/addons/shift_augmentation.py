"""Shift augmentation of arm pushes (``algo.shift_cells`` = m > 0; ours, off by default).

Each sampled transition whose action is an arm push gets its RGB-D image translated by a random
whole number of Q-map cells, up to m in each direction (edge pixels repeated, as DrQ's padded
random crop), and its push cell moved by the same amount: the push lands on the same surface, so
it keeps its reward. The Q maps are then fitted to the same outcome at many places in the image,
and a place alone no longer predicts it. Why here: in ArrangeKitchenMM the greedy push of the
reward-only runs was the same cell and bin in all of 16 oracle states (results/sgpd-explore,
tenth session): the maps had learned which places pay on average, not what is there. Drawer
fronts and door edges look alike wherever they appear, so translation is a prior the task
allows, in the spirit of DrQ (Kostrikov et al. 2021) and of Transporter networks' translation
equivariance (Zeng et al. 2020). Shifts keep the cell inside the map; base actions, the local map
and the next state (the TD target) are left as they are. Only the task reward is used.

Measured in ``results/sgpd-explore`` (eleventh session), ArrangeKitchenMM seed 0 with m = 3: an
update costs the same (0.75-0.81 against 0.80-0.84 CPU s), and at episode 300 the greedy push
was still one cell and bin in 15 of 16 oracle states: not yet a fix at that length.
"""

from __future__ import annotations

import torch as th

from relmogen.envs.subgoal_controls import decode_indices, encode_indices


def random_cell_shifts(cells: th.Tensor, q: int, max_cells: int, movable: th.Tensor) -> th.Tensor:
    """Per-sample shifts in [-max_cells, max_cells] that keep ``cells`` (B,) inside [0, q); 0 where
    not ``movable``."""
    low = th.clamp(-cells, min=-max_cells)
    high = th.clamp(q - 1 - cells, max=max_cells)
    shifts = low + th.floor(th.rand(cells.shape, device=cells.device) * (high - low + 1)).long()
    return th.where(movable, shifts, th.zeros_like(shifts))


def translate_images(images: th.Tensor, rows: th.Tensor, cols: th.Tensor) -> th.Tensor:
    """(B, C, H, W) images moved down by ``rows`` and right by ``cols`` pixels (B,), edge pixels
    repeated: out[b, :, r, c] = images[b, :, clamp(r - rows[b]), clamp(c - cols[b])]."""
    batch, channels, height, width = images.shape
    source_rows = th.clamp(th.arange(height, device=images.device)[None] - rows[:, None], 0, height - 1)
    source_cols = th.clamp(th.arange(width, device=images.device)[None] - cols[:, None], 0, width - 1)
    moved = images.gather(2, source_rows[:, None, :, None].expand(batch, channels, height, width))
    return moved.gather(3, source_cols[:, None, None, :].expand(batch, channels, height, width))


def translate_observation(image: th.Tensor, rows: th.Tensor, cols: th.Tensor, channels_first: bool) -> th.Tensor:
    """``translate_images`` on an observation tensor in either layout, returned in its own layout."""
    if channels_first:
        return translate_images(image, rows, cols)
    return translate_images(image.permute(0, 3, 1, 2), rows, cols).permute(0, 2, 3, 1)


def shift_arm_pushes(observations: dict[str, th.Tensor], actions: th.Tensor, q: int, max_cells: int,
                     rgb_channels_first: bool) -> tuple[dict[str, th.Tensor], th.Tensor]:
    """The batch with every arm push's image and cell shifted together (see the module docstring).
    ``actions`` (B, 1) are SGP-D indices (``decode_indices`` order)."""
    image_size = observations["rgb"].shape[-1] if rgb_channels_first else observations["rgb"].shape[-2]
    pixels_per_cell = image_size // q
    index = actions.reshape(-1).long()
    is_arm, push_bin, i, j = decode_indices(index, q)
    di = random_cell_shifts(i, q, max_cells, is_arm)
    dj = random_cell_shifts(j, q, max_cells, is_arm)
    rows, cols = di * pixels_per_cell, dj * pixels_per_cell
    shifted = dict(observations)
    shifted["rgb"] = translate_observation(observations["rgb"], rows, cols, rgb_channels_first)
    depth = observations["depth"]
    shifted["depth"] = translate_observation(depth, rows, cols, channels_first=depth.shape[-1] != 1)
    moved = encode_indices(True, push_bin, i + di, j + dj, q)
    return shifted, th.where(is_arm, moved, index).reshape(actions.shape).to(actions.dtype)
