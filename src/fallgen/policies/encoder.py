"""The observation encoder the three learned policies share (plain torch).

Input: the compact observations (:class:`fallgen.env.wrappers.Compactor`, the environment's
own made small) as tensors with a batch axis and the images channels first
(:func:`to_tensors`):

- ``rgb`` (B, 3, 84, 84), ``depth`` (B, 1, 84, 84) (10 m over 255 levels) and
  ``category_seg`` (B, 1, 84, 84) (the category index + 1, 0 for nothing), 0..255 as stored;
- ``audio`` (B, 128): the step-0 clip's log-mel band energies, 64 per ear, in [0, 1];
- ``pose`` (B, 4): forward and left of the spawn (m), heading and tilt (rad).

The segmentation's categories are embedded (4 numbers each), stacked with colour and depth
into one image of 8 channels and read by the Atari CNN (Mnih et al. 2015: 32 8x8/4, 64 4x4/2,
64 3x3/1, then 256 units); the clip's bands by two layers (128, 64); the pose as (x / 10,
y / 10, cos, sin of the heading, tilt) by one (32). Output: the three concatenated, 352
numbers. The paper gave RGB-D, segmentation and spectrogram a CNN each; one CNN over the
stacked channels costs a third on a CPU.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
import torch
from torch import nn

IMAGE_KEYS = ("rgb", "depth", "category_seg")
VECTOR_KEYS = ("audio", "pose")
KEYS = IMAGE_KEYS + VECTOR_KEYS
#: Numbers each segmentation category is embedded in.
SEG_EMBED = 4
VISUAL_DIM, AUDIO_DIM, POSE_DIM = 256, 64, 32
FEATURES_DIM = VISUAL_DIM + AUDIO_DIM + POSE_DIM


def to_tensors(obs: Mapping[str, np.ndarray], device: Any = "cpu",
               batched: bool = True) -> dict[str, torch.Tensor]:
    """Compact observations (numpy, images channels last; ``batched``: with leading batch
    axes, else one observation) -> the encoder's tensors (images channels first)."""
    out = {}
    for k in KEYS:
        a = np.asarray(obs[k])
        if not batched:
            a = a[None]
        if k in IMAGE_KEYS:
            a = np.moveaxis(a, -1, -3)
        out[k] = torch.as_tensor(np.ascontiguousarray(a), device=device)
    return out


class ObservationEncoder(nn.Module):
    """Compact observations -> (B, :data:`FEATURES_DIM`) features (module docstring)."""

    out_dim = FEATURES_DIM

    def __init__(self, bands: int = 64, size: int = 84) -> None:
        super().__init__()
        self.seg = nn.Embedding(256, SEG_EMBED)
        self.cnn = nn.Sequential(
            nn.Conv2d(4 + SEG_EMBED, 32, 8, stride=4), nn.ReLU(),
            nn.Conv2d(32, 64, 4, stride=2), nn.ReLU(),
            nn.Conv2d(64, 64, 3, stride=1), nn.ReLU(), nn.Flatten())
        with torch.no_grad():
            n = self.cnn(torch.zeros(1, 4 + SEG_EMBED, size, size)).shape[1]
        self.visual = nn.Sequential(nn.Linear(n, VISUAL_DIM), nn.ReLU())
        self.audio = nn.Sequential(nn.Linear(2 * bands, 128), nn.ReLU(),
                                   nn.Linear(128, AUDIO_DIM), nn.ReLU())
        self.pose = nn.Sequential(nn.Linear(5, POSE_DIM), nn.ReLU())

    def image(self, obs: Mapping[str, torch.Tensor]) -> torch.Tensor:
        """The stacked (B, 8, H, W) image of colour, depth and embedded categories."""
        rgb = obs["rgb"].float() / 255.0
        depth = obs["depth"].float() / 255.0
        seg = self.seg(obs["category_seg"][:, 0].long()).permute(0, 3, 1, 2)
        return torch.cat([rgb, depth, seg], dim=1)

    def forward(self, obs: Mapping[str, torch.Tensor]) -> torch.Tensor:
        v = self.visual(self.cnn(self.image(obs)))
        a = self.audio(obs["audio"].float())
        p = obs["pose"].float()
        p = torch.stack([p[:, 0] / 10.0, p[:, 1] / 10.0, torch.cos(p[:, 2]),
                         torch.sin(p[:, 2]), p[:, 3]], dim=1)
        return torch.cat([v, a, self.pose(p)], dim=1)


def compactor(sample_rate: int, sensors=("rgb", "depth", "audio", "pose", "category_seg")):
    """The :class:`~fallgen.env.wrappers.Compactor` that makes the environment's own
    observations (``sensors``) what the encoder reads, for an agent outside the training
    wrapper (``fallgen evaluate``)."""
    from fallgen.env.wrappers import Compactor

    return Compactor(raw_spaces(sensors), sample_rate)


def raw_spaces(sensors) -> dict[str, Any]:
    """The environment's observation spaces of ``sensors`` as far as :class:`Compactor` reads
    them (the clip's length and the category count do not matter to it)."""
    from gymnasium import spaces

    from fallgen.env.fallen_objects import DEPTH_MAX_M, POSE_LIMIT_M
    from fallgen.vision.camera import HEIGHT, WIDTH

    lim = np.float32(POSE_LIMIT_M)
    known = {
        "rgb": spaces.Box(0, 255, (HEIGHT, WIDTH, 3), np.uint8),
        "depth": spaces.Box(0.0, DEPTH_MAX_M, (HEIGHT, WIDTH, 1), np.float32),
        "audio": spaces.Box(-1.0, 1.0, (2, 1), np.float32),
        "pose": spaces.Box(-lim, lim, (4,), np.float32),
        "category_seg": spaces.Box(-1, 254, (HEIGHT, WIDTH, 1), np.int16),
    }
    return {k: known[k] for k in sensors}


__all__ = ["KEYS", "IMAGE_KEYS", "FEATURES_DIM", "ObservationEncoder", "to_tensors",
           "compactor", "raw_spaces"]
