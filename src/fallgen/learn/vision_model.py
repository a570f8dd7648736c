"""The visual perception module: semantic segmentation of the dataset's 31 target categories
(everything else one class, ``other``) from the agent's 300 x 300 RGB and depth, by a small
fully convolutional network (:class:`fallgen.learn.nets.SegNet`) trained on a build's train
split (``fallgen vision-model train``).

Input: RGB scaled to about zero mean and unit spread, and the log of depth likewise (4
channels); output: class scores at 150 x 150, the label map doubled to 300 x 300. A pixel is an
object's when its best target category outscores ``other`` by :attr:`VisionModel.margin`
(chosen on the validation split when it is trained). An agent that knows which categories it
looks for asks for those (``asked``): a pixel is then of the best of them where it outscores
``other`` by :attr:`VisionModel.ask_margin`, whatever the other categories score (the network
knows an object from the floor far better than a fork from a knife).

Training: :mod:`fallgen.learn.vision_train`.

The model file (``torch.save`` of plain tensors and settings, read back with
``weights_only=True``) holds the network's shape and weights, the class names, the dataset's
category table, its manifest hash, the margin, the settings and the learning curve; a file that
is not a model, or one trained on another dataset, is refused in one line
(:class:`fallgen.errors.InputError`).
"""

from __future__ import annotations

import io
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from fallgen.errors import InputError
from fallgen.learn import require_torch
from fallgen.learn.frames import TARGET_BIT
from fallgen.learn.nets import NetConfig

FORMAT = "fallgen-vision-model/1"
#: what the scores call the fallen object found / seen by mistake (pixels of 300 x 300)
FOUND_PIXELS = 4
FOUND_SHOWN_PIXELS, FOUND_WITHIN_M = 50, 2.0
RGB_MEAN, RGB_STD = 0.45, 0.25
LOGD_MEAN, LOGD_STD = 0.8, 0.7


def to_input(rgb: np.ndarray, depth: np.ndarray) -> np.ndarray:
    """(N, 4, H, W) float32 network input of RGB (N, H, W, 3) uint8 and depth (N, H, W) m."""
    x = np.empty((rgb.shape[0], 4, *rgb.shape[1:3]), np.float32)
    x[:, :3] = (np.moveaxis(rgb, -1, 1).astype(np.float32) * (1 / 255.0) - RGB_MEAN) / RGB_STD
    d = np.log(np.clip(np.asarray(depth, np.float32), 0.1, 50.0))
    x[:, 3] = (d - LOGD_MEAN) / LOGD_STD
    return x


@dataclass
class VisionModel:
    """A trained segmentation network with what it needs to be used on a dataset."""

    config: NetConfig
    state: dict  # the network's weights (state_dict of tensors)
    classes: tuple[str, ...]  # "other", then the target categories
    category_labels: tuple[str, ...]  # the dataset's segmentation table
    manifest_sha256: str = ""
    margin: float = 0.0
    meta: dict = field(default_factory=dict)
    #: the margin when categories are asked for (:meth:`scores`' ``asked``)
    ask_margin: float = 0.0
    _net: object = field(default=None, repr=False, compare=False)
    _device: object = field(default=None, repr=False, compare=False)

    # -- inference ------------------------------------------------------------------------
    def set_state(self, state: dict) -> None:
        """New weights (a state_dict); the inference network is made again from them."""
        self.state = state
        self._net = self._device = None

    def network(self, device=None):
        """The inference network (batch normalisation folded, eval mode) on ``device``."""
        torch = require_torch()
        from fallgen.learn.nets import SegNet, fused

        device = torch.device(device or "cpu")
        if self._net is None or self._device != device:
            net = SegNet(self.config)
            net.load_state_dict(self.state)
            self._net, self._device = fused(net).to(device), device
        return self._net

    def scores(self, rgb: np.ndarray, depth: np.ndarray, device=None,
               asked: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """(the best target class (N, h, w) uint8 at half resolution, how much its score
        beats ``other``'s (N, h, w) float32) for RGB (N, H, W, 3) and depth (N, H, W).
        ``asked``: the classes to choose from ((k,) for every frame, or (N, k) per frame)
        instead of all the targets, for an agent that knows what it looks for: it asks
        which pixels are of those categories, not which category each pixel is."""
        torch = require_torch()
        net = self.network(device)
        x = torch.from_numpy(to_input(rgb, depth)).to(self._device)
        x = x.contiguous(memory_format=torch.channels_last)
        with torch.inference_mode():
            y = net(x)
            if asked is None:
                best, idx = y[:, 1:].max(1)
                idx = idx + 1
            else:
                n, _, h, w = y.shape
                a = np.broadcast_to(np.asarray(asked, np.int64).reshape(
                    (1, -1) if np.ndim(asked) <= 1 else (n, -1)), (n, np.shape(asked)[-1]))
                a = torch.from_numpy(np.array(a, copy=True)).to(y.device)
                cand = y.gather(1, a[:, :, None, None].expand(-1, -1, h, w))
                best, j = cand.max(1)
                idx = a.gather(1, j.reshape(n, -1)).reshape(n, h, w)
            lead = best - y[:, 0]
        return idx.to(torch.uint8).cpu().numpy(), lead.float().cpu().numpy()

    def predict(self, rgb: np.ndarray, depth: np.ndarray, margin: float | None = None,
                device=None, asked: np.ndarray | None = None) -> np.ndarray:
        """(N, H, W) uint8 classes (0: other) of RGB (N, H, W, 3) and depth (N, H, W);
        ``asked`` as for :meth:`scores` (then :attr:`ask_margin` by default)."""
        best, lead = self.scores(rgb, depth, device, asked)
        if margin is None:
            margin = self.margin if asked is None else self.ask_margin
        return full_size(labels_at(best, lead, margin))

    def category_lookup(self) -> np.ndarray:
        """Class -> index into :attr:`category_labels` (-1 for ``other``)."""
        out = np.full(len(self.classes), -1, np.int16)
        for k, name in enumerate(self.classes[1:], start=1):
            if name in self.category_labels:
                out[k] = self.category_labels.index(name)
        return out

    # -- files ----------------------------------------------------------------------------
    def save(self, path: str | Path) -> Path:
        torch = require_torch()
        from fallgen.atomic import write_bytes

        buf = io.BytesIO()
        torch.save({"format": FORMAT, "config": self.config.to_dict(),
                    "state": {k: v.detach().cpu() for k, v in self.state.items()},
                    "classes": list(self.classes), "category_labels": list(self.category_labels),
                    "manifest_sha256": self.manifest_sha256, "margin": float(self.margin),
                    "ask_margin": float(self.ask_margin), "meta": self.meta}, buf)
        return write_bytes(Path(path), buf.getvalue())

    @staticmethod
    def load(path: str | Path) -> VisionModel:
        """The model in ``path``; :class:`InputError` (one line) for anything else."""
        torch = require_torch()
        path = Path(path)
        if not path.is_file():
            raise InputError(path, "<file>", "no such model file")
        try:
            d = torch.load(path, map_location="cpu", weights_only=True)
        except Exception as e:  # noqa: BLE001 - a truncated or foreign file
            raise InputError(path, "<file>", f"not a fallgen vision model "
                             f"({type(e).__name__})") from None
        if not isinstance(d, dict) or d.get("format") != FORMAT:
            raise InputError(path, "format", f"not a {FORMAT} file")
        for k in ("config", "state", "classes", "category_labels"):
            if k not in d:
                raise InputError(path, k, "missing: train it again")
        try:
            config = NetConfig.from_dict(d["config"])
        except (KeyError, TypeError, ValueError) as e:
            raise InputError(path, "config", f"unreadable network shape ({e})") from None
        m = VisionModel(config, dict(d["state"]), tuple(d["classes"]),
                        tuple(d["category_labels"]), str(d.get("manifest_sha256", "")),
                        float(d.get("margin", 0.0)), dict(d.get("meta", {})),
                        float(d.get("ask_margin", d.get("margin", 0.0))))
        try:
            m.network()
        except RuntimeError as e:
            raise InputError(path, "state", f"weights do not fit the network "
                             f"({str(e).splitlines()[0]})") from None
        return m

    def check_dataset(self, ds, path: str | Path) -> None:
        """One-line :class:`InputError` when ``ds`` is not the dataset the model was
        trained on (its manifest hash) or segments with another category table."""
        from fallgen.dataset.manifest import manifest_sha256

        have = manifest_sha256(ds.root) or ""
        if self.manifest_sha256 != have:
            raise InputError(path, "manifest_sha256", f"trained on the dataset with manifest "
                             f"{self.manifest_sha256[:12] or '(none)'}...; {ds.root} has "
                             f"{have[:12] or '(none)'}...: train it on this dataset")
        labels = tuple(ds.category_labels)
        if labels and labels != self.category_labels:
            raise InputError(path, "category_labels", f"the model's category table differs "
                             f"from {ds.root}'s")


def labels_at(best: np.ndarray, lead: np.ndarray, margin: float) -> np.ndarray:
    """Classes where the best target class leads ``other`` by more than ``margin``."""
    return np.where(lead > margin, best, 0).astype(np.uint8)


def full_size(labels: np.ndarray) -> np.ndarray:
    """(N, h, w) half-resolution labels doubled to (N, 2h, 2w)."""
    return labels.repeat(2, axis=-2).repeat(2, axis=-1)


def frame_target(label: np.ndarray) -> np.ndarray:
    """The fallen object's own pixels of stored labels."""
    return (label & TARGET_BIT) != 0


__all__ = ["FORMAT", "VisionModel", "to_input", "labels_at", "full_size", "frame_target",
           "FOUND_PIXELS", "FOUND_SHOWN_PIXELS", "FOUND_WITHIN_M"]
