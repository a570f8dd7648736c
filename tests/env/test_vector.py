"""make_vec's VectorEnv when its workers cannot start: the worker's error, and nothing raised
later by the garbage collector's close."""

from __future__ import annotations

import functools
import gc
import sys

import pytest

pytestmark = pytest.mark.xdist_group("tiny_build")


def test_a_worker_that_fails_raises_once_and_closes_cleanly(tiny_dataset, tmp_path,
                                                           monkeypatch):
    """The first environment starts (Gymnasium makes a copy of it in this process for the
    spaces); the second's dataset does not exist, so its worker fails before it answers. The
    constructor raises (Gymnasium's error: the worker's pipe closed); dropping the half-made
    vector env closes it without another exception (it used to raise AttributeError from
    __del__: the pending steps were set after the start)."""
    from fallgen.env import FallenObjectsEnv
    from fallgen.env.vector import VectorEnv

    unraised: list = []
    monkeypatch.setattr(sys, "unraisablehook", unraised.append)
    fns = [functools.partial(FallenObjectsEnv, str(tiny_dataset), sensors=("pose",)),
           functools.partial(FallenObjectsEnv, str(tmp_path / "missing"), sensors=("pose",))]
    with pytest.raises(OSError):
        VectorEnv(fns, shared_memory=True, context="spawn")
    gc.collect()
    assert [u.exc_value for u in unraised] == []
    # the hook does record what __del__ raises (the check can fail)
    class Bad:
        def __del__(self):
            raise AttributeError("_pending")

    Bad()
    gc.collect()
    assert len(unraised) == 1 and isinstance(unraised[0].exc_value, AttributeError)


def test_shared_memory_is_required_before_any_worker_starts(tiny_dataset):
    from fallgen.env import FallenObjectsEnv
    from fallgen.env.vector import VectorEnv

    fns = [functools.partial(FallenObjectsEnv, str(tiny_dataset), sensors=("pose",))]
    with pytest.raises(ValueError, match="shared_memory=True"):
        VectorEnv(fns, shared_memory=False, context="spawn")
