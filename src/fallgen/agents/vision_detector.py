"""The learned visual perception module as the modular agent's eyes: a
:class:`fallgen.agents.modular.Detector` that segments each step's RGB-D view with a
:class:`fallgen.learn.vision_model.VisionModel` (``fallgen vision-model train``).

The paper's modular agent used a Mask R-CNN trained on the dataset's categories; ours is a
small encoder-decoder (:mod:`fallgen.learn.nets`) that segments a frame in ~10 ms on one CPU
core. Its label map is in the dataset's category table (-1 where it sees no target category),
like the ``category_seg`` oracle's, so the agent uses it exactly where it would use the
oracle. torch is imported only when a detector is made (``pip install 'fallgen[learn]'``).
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

import numpy as np


class VisionDetector:
    """A :class:`fallgen.agents.modular.Detector` from a vision model (or its file).
    ``threads``: torch's intra-op threads while it segments (set for each call and restored
    after; evaluation runs one agent per worker process, so one thread each); ``margin``: by
    how much a target category must outscore ``other`` (None: the model's own)."""

    sensors = ("rgb", "depth")

    def __init__(self, model, threads: int = 1, device: str = "cpu",
                 margin: float | None = None) -> None:
        from fallgen.learn.vision_model import VisionModel

        self.model = model if isinstance(model, VisionModel) else VisionModel.load(Path(model))
        self.lookup = self.model.category_lookup()
        self.class_of = {int(c): k for k, c in enumerate(self.lookup) if c >= 0}
        self.threads, self.device, self.margin = int(threads), device, margin

    def segment(self, obs: Mapping[str, np.ndarray], targets=None) -> np.ndarray:
        """(H, W) int16 indices into the dataset's category labels (-1: no target).
        ``targets``: the categories the agent looks for (indices into the labels); when
        they are fewer than the model's, the network is asked for those alone (a pixel is
        the likeliest of them where it outscores ``other`` by the model's ask margin)."""
        from fallgen.learn.runtime import session

        rgb = np.asarray(obs["rgb"])[None]
        depth = np.asarray(obs["depth"], np.float32).reshape(rgb.shape[1:3])[None]
        asked = None
        if targets is not None:
            asked = sorted({self.class_of[int(t)] for t in np.ravel(targets)
                            if int(t) in self.class_of})
            if not asked or len(asked) >= len(self.class_of):
                asked = None
        margin = self.margin if self.margin is not None or asked is None else None
        with session(self.threads, deterministic=False):
            classes = self.model.predict(rgb, depth, margin, self.device,
                                         None if asked is None else np.asarray(asked))[0]
        return self.lookup[classes]


__all__ = ["VisionDetector"]
