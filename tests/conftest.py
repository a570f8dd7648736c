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
