"""Shared fixtures: the built-in world, loaded once per test process."""

from __future__ import annotations

import os
import shutil
from pathlib import Path

import pytest

os.environ.setdefault("MUJOCO_GL", "egl")
import sys  # noqa: E402

assert "numpy" not in sys.modules or os.environ.get("OPENBLAS_NUM_THREADS") == "1", \
    "numpy was imported before fallgen could pin BLAS to one thread"
for _v in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_v, "1")

REPO = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="session")
def world():
    from fallgen.world.library import load_world

    return load_world(REPO)


@pytest.fixture
def data_copy(tmp_path: Path) -> Path:
    """A writable copy of the built-in data directories, to break on purpose."""
    root = tmp_path / "data"
    for d in ("materials", "objects", "rooms"):
        shutil.copytree(REPO / d, root / d)
    return root


# --- a tiny dataset, built once per test process (tests that use it share an xdist group) ---

TINY_CONFIG = """
[build]
root_seed = 7
out = "{out}"

[rehearse]
rooms = "kitchen_galley-l1-m1,study_office-l1-m1"
zones = "z0[0-3]"
events_per_zone = 1
max_trials_per_zone = 4
drop_height_m = [1.5, 2.8]
min_fall_m = 0.3             # every kept event falls at least this far before its first impact
push_speed_mps = 0.15
spin_radps = 2.0
settle_lin_mps = 0.01
settle_ang_radps = 0.1
settle_hold_s = 0.25
timeout_s = 6.0

[generate]
episodes = {{ train = 2, validation = 2, test = 2 }}
frames = "first"
hrtf = "sadie_ku100"
audio_s = 1.0
image_source_order = 3
ambient_noise_db_a = 30.0
min_heard_peak_db_spl = 0.0
episodes_per_shard = 2
"""


def run_cli(*args) -> int:
    """``fallgen ARGS`` in this process; the exit code."""
    from fallgen.cli import main

    try:
        main(list(args))
    except SystemExit as e:
        return int(e.code or 0)
    return 0


def digest(root: Path, dirs=("data", "media")) -> dict[str, str]:
    """sha256 of the files (not temporaries) in ``dirs`` of ``root`` ("." for its own)."""
    import hashlib

    return {str(p.relative_to(root)): hashlib.sha256(p.read_bytes()).hexdigest()
            for d in dirs for p in sorted((root / d).glob("*"))
            if p.is_file() and not p.name.endswith(".tmp") and not p.name.startswith(".")}


@pytest.fixture(name="cli", scope="session")
def _cli():
    """``cli("validate", path)``: run the command line here, return the exit code."""
    return run_cli


@pytest.fixture(name="digest", scope="session")
def _digest():
    return digest


@pytest.fixture(scope="session")
def tiny_build(tmp_path_factory):
    """(base, config): a two-room, six-episode dataset built into base/one with one worker
    and into base/two with two; the modal cache in base/cache (unless FALLGEN_CACHE is set).
    Mark tests that use it ``pytest.mark.xdist_group("tiny_build")``."""
    base = tmp_path_factory.mktemp("gen")
    os.environ.setdefault("FALLGEN_CACHE", str(base / "cache"))
    cfg = base / "tiny.toml"
    cfg.write_text(TINY_CONFIG.format(out=base / "one"))
    assert run_cli("generate", "-c", str(cfg)) == 2  # no rehearsal yet: one-line error
    assert run_cli("rehearse", "-c", str(cfg), "--workers", "1") == 0
    shutil.copytree(base / "one" / "rehearsal", base / "two" / "rehearsal")
    assert run_cli("generate", "-c", str(cfg), "--workers", "1") == 0
    assert run_cli("generate", "-c", str(cfg), "--out", str(base / "two"), "--workers", "2") == 0
    return base, cfg


@pytest.fixture(scope="session")
def tiny_dataset(tiny_build):
    """The tiny build made with one worker (base/one of :func:`tiny_build`)."""
    base, _ = tiny_build
    return base / "one"
