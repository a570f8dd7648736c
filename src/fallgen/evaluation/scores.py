"""Scores of an evaluation: means, 95 % confidence intervals and breakdowns (``summary.json``),
and the paper's Table 1 layout for the terminal and the README.

Measures per episode (from the environment): success (S), SPL = S l / max(p, l) and
SNA = S n* / max(n, n*) (Anderson et al. 2018 and the paper), soft SPL (progress along the
geodesic distance times l / max(p, l)). Confidence intervals: SciPy's percentile bootstrap
of the mean (``scipy.stats.bootstrap``, 2000 resamples drawn from a generator with a fixed
seed, so the same records give the same intervals), which suits measures bounded in [0, 1]
and piled up at 0 and 1.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

MEASURES = ("success", "spl", "sna", "soft_spl")
BOOTSTRAP = 2000
BREAKDOWNS = ("room_kind", "zone_kind", "category")

#: The paper's Table 1 (1000 test episodes; SR / SPL / SNA) and Table 2 (cross-scene, modular).
PAPER_TABLE1 = (
    ("Decision Transformer", 0.17, 0.12, 0.14),
    ("PPO (oracle found)", 0.19, 0.15, 0.14),
    ("SAVi", 0.23, 0.16, 0.10),
    ("Object-Goal", 0.22, 0.18, 0.17),
    ("Modular Planning", 0.41, 0.27, 0.25),
    ("  + GT segmentation", 0.47, 0.34, 0.32),
    ("  + GT object", 0.67, 0.41, 0.38),
    ("  + GT segmentation + object", 0.85, 0.61, 0.56),
    ("  + GT segmentation + object + location", 0.93, 0.83, 0.80),
)
PAPER_TABLE2 = {"kitchen_to_study": ("Modular Planning", 0.34, 0.23, 0.20),
                "study_to_kitchen": ("Modular Planning", 0.35, 0.22, 0.19)}


def bootstrap_ci(values: Sequence[float], level: float = 0.95, n: int = BOOTSTRAP,
                 seed: int = 0) -> tuple[float, float]:
    """Percentile bootstrap interval of the mean of ``values`` (``scipy.stats.bootstrap``,
    ``n`` resamples from ``numpy.random.default_rng(seed)``); a single value is its own
    interval, none gives NaNs."""
    from scipy.stats import bootstrap

    x = np.asarray(values, float)
    if len(x) == 0:
        return (float("nan"), float("nan"))
    if len(x) == 1:  # every resample is the value itself (SciPy wants two)
        return (float(x[0]), float(x[0]))
    ci = bootstrap((x,), np.mean, n_resamples=n, confidence_level=level, method="percentile",
                   vectorized=True, rng=np.random.default_rng(seed)).confidence_interval
    return (float(ci.low), float(ci.high))


def _means(records: Sequence[dict]) -> dict[str, float]:
    return {m: float(np.mean([float(r[m]) for r in records])) for m in MEASURES}


def summarize(records: Sequence[dict], meta: dict[str, Any]) -> dict[str, Any]:
    """``summary.json``: the means of :data:`MEASURES` at the top level, then ``n``,
    ``ci95``, ``outcomes``, mean steps, breakdowns by room kind, zone kind and category, and
    ``meta`` (dataset, manifest hash, version, agent, selection)."""
    if not records:
        raise ValueError("no episodes to score")
    out: dict[str, Any] = _means(records)
    out["n"] = len(records)
    out["ci95"] = {m: list(bootstrap_ci([float(r[m]) for r in records])) for m in MEASURES}
    kinds = ("found", "wrong_found", "timeout")
    out["outcomes"] = {k: sum(r["outcome"] == k for r in records) for k in kinds}
    out["mean_steps"] = float(np.mean([r["steps"] for r in records]))
    seen = [r["first_seen_step"] for r in records if r["first_seen_step"] >= 0]
    out["seen_share"] = len(seen) / len(records)
    for key in BREAKDOWNS:
        groups: dict[str, list[dict]] = {}
        for r in records:
            groups.setdefault(str(r[key]), []).append(r)
        out[f"by_{key}"] = {k: {"n": len(v), **_means(v)} for k, v in sorted(groups.items())}
    out.update(meta)
    return out


def manifest_hash(dataset: Path) -> str | None:
    """sha256 of the dataset's ``manifest.json`` (None when it has none: an unfinished build)."""
    from fallgen.dataset.manifest import manifest_sha256

    return manifest_sha256(dataset)


def table_rows(summary: dict[str, Any], label: str) -> list[tuple[str, str, str, str]]:
    """The agent's row of Table 1: (method, SR, SPL, SNA) with their intervals."""
    ci = summary["ci95"]

    def cell(m: str) -> str:
        return f"{summary[m]:.2f} [{ci[m][0]:.2f}, {ci[m][1]:.2f}]"

    return [(label, cell("success"), cell("spl"), cell("sna"))]


def markdown_table(rows: Sequence[Sequence[str]],
                   header: Sequence[str] = ("Method", "SR", "SPL", "SNA")) -> str:
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(str(c) for c in r) + " |" for r in rows]
    return "\n".join(lines) + "\n"


__all__ = ["MEASURES", "PAPER_TABLE1", "PAPER_TABLE2", "bootstrap_ci", "summarize",
           "manifest_hash", "table_rows", "markdown_table"]
