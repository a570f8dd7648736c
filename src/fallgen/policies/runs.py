"""A training run's directory: what it was trained on, its checkpoints, its log and its curve.

    RUN/run.json                  kind, dataset, its manifest hash, the settings, the seed
    RUN/checkpoints/ckpt-NNNNNN.pt  after update NNNNNN (the last KEEP are kept)
    RUN/log.csv                   a row per logged update (the columns are the policy's)
    RUN/curve.png                 the learning curve (drawn from log.csv)

A checkpoint is one ``torch.save`` file of tensors and plain values (read back with
``weights_only=True``): ``format``, ``kind``, ``manifest_sha256``, ``dataset``, ``config``,
``update``, ``state`` (the policy's), ``rng`` (:func:`fallgen.learn.runtime.rng_state`).
A run is resumed from its last checkpoint; a checkpoint made on another dataset (another
manifest hash), of another kind or with other settings is refused with one line
(:class:`fallgen.errors.InputError`).
"""

from __future__ import annotations

import csv
import json
import math
import os
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from fallgen.errors import InputError

FORMAT = "fallgen-policy/2"
#: Checkpoints kept (the newest).
KEEP = 3


def dataset_hash(dataset: str | Path) -> str:
    """The dataset's manifest hash; InputError when it has no manifest (an unfinished build)."""
    from fallgen.dataset.manifest import manifest_sha256

    h = manifest_sha256(Path(dataset))
    if not h:
        raise InputError(Path(dataset) / "manifest.json", "<file>", "no manifest: train on a "
                         "finished build")
    return h


class Run:
    """The run directory ``root`` (made when the first file is written)."""

    def __init__(self, root: str | Path) -> None:
        self.root = Path(root)
        self.checkpoints = self.root / "checkpoints"
        self.log_path = self.root / "log.csv"
        self.curve_path = self.root / "curve.png"
        self.meta_path = self.root / "run.json"

    # --- run.json ---------------------------------------------------------------------------

    def meta(self) -> dict[str, Any] | None:
        if not self.meta_path.exists():
            return None
        try:
            return json.loads(self.meta_path.read_text())
        except (OSError, ValueError) as e:
            raise InputError(self.meta_path, "<file>", f"unreadable: {e}") from None

    def start(self, kind: str, dataset: str | Path, digest: str, config: Mapping[str, Any],
              given: Mapping[str, Any]) -> dict[str, Any]:
        """The run's settings: a new run's ``config`` (written to run.json), or a resumed
        run's as it was started. Refused (InputError) where the run is of another kind, of
        another dataset, or where a setting ``given`` on this command line differs from the
        run's."""
        meta = self.meta()
        if meta is None:
            if self.latest() is not None:
                raise InputError(self.meta_path, "<file>", "missing beside checkpoints")
            self.root.mkdir(parents=True, exist_ok=True)
            meta = {"format": FORMAT, "kind": kind, "dataset": str(Path(dataset).resolve()),
                    "manifest_sha256": digest, "config": dict(config)}
            tmp = self.meta_path.with_suffix(".json.tmp")
            tmp.write_text(json.dumps(meta, indent=1) + "\n")
            os.replace(tmp, self.meta_path)
            return dict(config)
        if meta.get("kind") != kind:
            raise InputError(self.meta_path, "kind", f"the run trains {meta.get('kind')!r}, "
                             f"not {kind!r} (another -o)")
        if meta.get("manifest_sha256") != digest:
            raise InputError(self.meta_path, "manifest_sha256", "the run was trained on "
                             f"another dataset ({meta.get('dataset')}, manifest "
                             f"{str(meta.get('manifest_sha256'))[:12]}); {dataset} has "
                             f"{digest[:12]} (another -o)")
        old = meta.get("config", {})
        for k, v in given.items():
            if k in old and old[k] != v:
                raise InputError(self.meta_path, f"config.{k}", f"the run was started with "
                                 f"{old[k]!r}, not {v!r} (resume without it, or another -o)")
        return dict(old)

    # --- checkpoints ------------------------------------------------------------------------

    def latest(self) -> Path | None:
        """The last checkpoint, if any."""
        found = sorted(self.checkpoints.glob("ckpt-*.pt")) if self.checkpoints.is_dir() else []
        return found[-1] if found else None

    def save(self, update: int, payload: dict[str, Any]) -> Path:
        """Write checkpoint ``update`` (atomically) and drop all but the last :data:`KEEP`."""
        import torch

        self.checkpoints.mkdir(parents=True, exist_ok=True)
        path = self.checkpoints / f"ckpt-{update:06d}.pt"
        tmp = path.with_suffix(".pt.tmp")
        torch.save({"format": FORMAT, "update": int(update), **payload}, tmp)
        os.replace(tmp, path)
        for old in sorted(self.checkpoints.glob("ckpt-*.pt"))[:-KEEP]:
            old.unlink()
        return path


def load_checkpoint(path: str | Path, kind: str | None = None,
                    digest: str | None = None, device: Any = "cpu") -> dict[str, Any]:
    """A checkpoint's contents; InputError (one line naming the file and the field) for a file
    that is not one, of another ``kind``, or made on a dataset whose manifest hash is not
    ``digest`` (None: not checked)."""
    import torch

    path = Path(path)
    try:
        ck = torch.load(path, map_location=device, weights_only=True)
    except Exception as e:  # a truncated or foreign file: one line
        raise InputError(path, "<file>", f"not a policy checkpoint ({type(e).__name__}: "
                         f"{str(e).splitlines()[0] if str(e) else ''})") from None
    if not isinstance(ck, dict) or ck.get("format") != FORMAT:
        raise InputError(path, "format", f"expected {FORMAT}")
    if kind is not None and ck.get("kind") != kind:
        raise InputError(path, "kind", f"a {ck.get('kind')!r} checkpoint, not {kind!r}")
    if digest is not None and ck.get("manifest_sha256") != digest:
        raise InputError(path, "manifest_sha256", "made on another dataset (manifest "
                         f"{str(ck.get('manifest_sha256'))[:12]}, this one {digest[:12]})")
    return ck


def find_checkpoint(run_or_file: str | Path) -> Path:
    """A checkpoint file, or the last checkpoint of a run directory; InputError if none."""
    p = Path(run_or_file)
    if p.is_file():
        return p
    last = Run(p).latest()
    if last is None:
        raise InputError(p, "checkpoints/", "no checkpoint (train first: fallgen train)")
    return last


def training_summary(ck: Mapping[str, Any]) -> dict[str, Any]:
    """What a checkpoint's training spent: ``steps`` (environment steps, or gradient steps for
    the Decision Transformer, ``unit``), ``updates``, ``wall_s``, ``settings``."""
    dt = ck.get("kind") == "dt"
    return {"kind": ck.get("kind"), "steps": int(ck.get("update" if dt else "timesteps", 0)),
            "unit": "gradient steps" if dt else "environment steps",
            "updates": int(ck.get("update", 0)), "wall_s": round(float(ck.get("wall_s", 0.0)), 1),
            "settings": dict(ck.get("config", {}))}


def apply_overrides(obj: Any, overrides: Mapping[str, Any] | None) -> Any:
    """The settings dataclass ``obj`` with ``overrides`` (name -> value, converted to each
    field's type); ValueError naming an unknown or malformed one."""
    from dataclasses import fields

    names = {f.name: f for f in fields(obj)}
    for k, v in (overrides or {}).items():
        if k not in names:
            raise ValueError(f"{k}: unknown setting (one of {', '.join(names)})")
        cur = getattr(obj, k)
        try:
            if v is None or (isinstance(v, str) and v.lower() in ("none", "")):
                val = None
            elif isinstance(cur, bool):
                val = v if isinstance(v, bool) else str(v).lower() in ("1", "true", "yes")
            elif isinstance(cur, int):
                val = int(float(v))
            elif isinstance(cur, float):
                val = float(v)
            else:
                val = v
        except (TypeError, ValueError):
            kind = {"int": "an integer", "float": "a number"}.get(type(cur).__name__,
                                                                  type(cur).__name__)
            raise ValueError(f"{k}={v!r}: not {kind}") from None
        setattr(obj, k, val)
    return obj


# --- the log and the curve --------------------------------------------------------------------

class CsvLog:
    """``log.csv``: a row per logged update; on resume the rows after the checkpoint's update
    are dropped (they were logged after it and will be made again)."""

    def __init__(self, path: Path, fields: Sequence[str], resume_update: int | None) -> None:
        self.path, self.fields = path, list(fields)
        rows = read_log(path) if path.exists() else []
        if resume_update is None:
            rows = []
        else:
            rows = [r for r in rows if int(float(r["update"])) <= resume_update]
        self._write_all(rows)

    def _write_all(self, rows: Sequence[Mapping[str, Any]]) -> None:
        self.path.parent.mkdir(parents=True, exist_ok=True)
        tmp = self.path.with_suffix(".csv.tmp")
        with open(tmp, "w", newline="") as f:
            w = csv.DictWriter(f, self.fields, extrasaction="ignore")
            w.writeheader()
            for r in rows:
                w.writerow(r)
        os.replace(tmp, self.path)

    def append(self, row: Mapping[str, Any]) -> None:
        with open(self.path, "a", newline="") as f:
            csv.DictWriter(f, self.fields, extrasaction="ignore").writerow(
                {k: _fmt(row.get(k, "")) for k in self.fields})


def _fmt(v: Any) -> Any:
    if isinstance(v, float):
        return "" if math.isnan(v) else f"{v:.6g}"
    return v


def read_log(path: str | Path) -> list[dict[str, str]]:
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def curve_png(path: str | Path, rows: Sequence[Mapping[str, Any]], x: str,
              panels: Sequence[tuple[str, Sequence[str]]], title: str,
              width: int = 900, panel_h: int = 200) -> Path:
    """A learning curve: a panel per (name, columns) of ``rows`` against column ``x``."""
    import cv2

    from fallgen.world.preview import write_png

    colours = [(31, 119, 180), (214, 39, 40), (44, 160, 44), (148, 103, 189)]
    left, right, top, gap = 70, 20, 30, 34
    h = top + len(panels) * (panel_h + gap) + 24
    img = np.full((h, width, 3), 255, np.uint8)
    cv2.putText(img, title[:110], (8, 20), cv2.FONT_HERSHEY_SIMPLEX, 0.5, (0, 0, 0), 1,
                cv2.LINE_AA)

    def col(name: str) -> np.ndarray:
        return np.array([float(r[name]) if str(r.get(name, "")) not in ("", "nan") else np.nan
                         for r in rows])

    xs = col(x) if rows else np.zeros(0)
    for p, (name, cols) in enumerate(panels):
        y0 = top + p * (panel_h + gap) + gap - 10
        x0, x1, y1 = left, width - right, y0 + panel_h
        cv2.rectangle(img, (x0, y0), (x1, y1), (160, 160, 160), 1)
        series = [(c, col(c)) for c in cols if rows]
        vals = np.concatenate([s for _, s in series]) if series else np.zeros(0)
        vals = vals[np.isfinite(vals)]
        good = np.isfinite(xs)
        if vals.size == 0 or not good.any():
            cv2.putText(img, f"{name}: no data yet", (x0 + 8, y0 + 20),
                        cv2.FONT_HERSHEY_SIMPLEX, 0.45, (0, 0, 0), 1, cv2.LINE_AA)
            continue
        lo, hi = float(vals.min()), float(vals.max())
        if hi - lo < 1e-9:
            lo, hi = lo - 0.5, hi + 0.5
        xl, xh = float(xs[good].min()), float(xs[good].max())
        xh = xh if xh > xl else xl + 1

        def px(xv, yv):
            return (int(x0 + (xv - xl) / (xh - xl) * (x1 - x0)),
                    int(y1 - (yv - lo) / (hi - lo) * (y1 - y0)))

        for k, (c, s) in enumerate(series):
            colour = colours[k % len(colours)]
            ok = np.isfinite(s) & good
            pts = [px(a, b) for a, b in zip(xs[ok], s[ok])]
            for a, b in zip(pts, pts[1:]):
                cv2.line(img, a, b, colour, 1, cv2.LINE_AA)
            for q in pts if len(pts) < 40 else ():
                cv2.circle(img, q, 2, colour, -1)
            cv2.putText(img, c, (x0 + 8 + 160 * k, y0 + 16), cv2.FONT_HERSHEY_SIMPLEX, 0.42,
                        colour, 1, cv2.LINE_AA)
        cv2.putText(img, name, (x0, y0 - 4), cv2.FONT_HERSHEY_SIMPLEX, 0.45, (0, 0, 0), 1,
                    cv2.LINE_AA)
        for v, yy in ((hi, y0 + 10), (lo, y1)):
            cv2.putText(img, f"{v:.3g}", (4, yy), cv2.FONT_HERSHEY_SIMPLEX, 0.4, (0, 0, 0), 1,
                        cv2.LINE_AA)
        cv2.putText(img, f"{x} {xl:.0f} to {xh:.0f}", (x1 - 220, y1 + 16),
                    cv2.FONT_HERSHEY_SIMPLEX, 0.4, (0, 0, 0), 1, cv2.LINE_AA)
    return write_png(img, path)


__all__ = ["FORMAT", "KEEP", "Run", "apply_overrides", "CsvLog", "dataset_hash", "load_checkpoint",
           "find_checkpoint", "training_summary", "read_log", "curve_png"]
