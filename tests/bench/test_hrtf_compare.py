"""bench/hrtf_compare.py (``make hrtf``): the two configs differ from the given one only in the
head and the episode counts, and the paired differences are what their names say."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

REPO = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(REPO / "bench"))

import hrtf_compare  # noqa: E402


def test_head_configs_differ_only_in_the_head_and_the_episodes(tmp_path):
    from fallgen.config import load_config

    text = (REPO / "configs" / "full.toml").read_text()
    base = load_config(REPO / "configs" / "full.toml")
    eps = {"train": 30, "validation": 5, "test": 10}
    for head in hrtf_compare.HEADS:
        path = tmp_path / f"{head}.toml"
        path.write_text(hrtf_compare.head_config(text, head, eps))
        cfg = load_config(path)
        assert cfg.generate.hrtf == head
        assert tuple(cfg.generate.episodes) == (30, 5, 10)  # train, validation, test
        assert cfg.rehearse == base.rehearse and cfg.root_seed == base.root_seed
        assert cfg.generate.image_source_order == base.generate.image_source_order
    with pytest.raises(SystemExit, match="hrtf"):
        hrtf_compare.head_config(text.replace('hrtf = "sadie_ku100"', ""), "sphere", eps)


def test_paired_difference_and_its_interval():
    a = np.array([1.0] * 30 + [0.0] * 70)
    b = np.array([1.0] * 50 + [0.0] * 50)
    d = hrtf_compare._paired(a, b, np.mean, 0)
    assert d["difference"] == pytest.approx(-0.2)
    lo, hi = d["ci95"]
    # the pairs differ in 20 of 100: the difference's standard error is ~0.04
    assert -0.31 < lo < -0.2 < hi < -0.09
    same = hrtf_compare._paired(a, a.copy(), np.mean, 0)
    assert same["difference"] == 0 and same["ci95"] == [0.0, 0.0]
