"""Atomic writes: whole files under final names, the user's umask for permissions."""

from __future__ import annotations

import os
import stat

import pytest

from fallgen import atomic


@pytest.mark.parametrize("mask", [0o022, 0o002, 0o077])
def test_new_files_get_the_umask_permissions(tmp_path, mask):
    old = os.umask(mask)
    try:
        assert atomic.umask() == mask
        p = atomic.write_text(tmp_path / "a.txt", "x")
        plain = tmp_path / "plain.txt"
        plain.write_text("x")
    finally:
        os.umask(old)
    assert stat.S_IMODE(p.stat().st_mode) == 0o666 & ~mask
    assert stat.S_IMODE(p.stat().st_mode) == stat.S_IMODE(plain.stat().st_mode)


def test_commit_renames_a_finished_file_and_leaves_no_temporary(tmp_path):
    tmp = tmp_path / "f.tmp"
    tmp.write_bytes(b"abc")
    out = atomic.commit(tmp, tmp_path / "f.bin")
    assert out.read_bytes() == b"abc" and not tmp.exists()
    atomic.write_bytes(tmp_path / "f.bin", b"new")
    assert (tmp_path / "f.bin").read_bytes() == b"new"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["f.bin"]


def test_a_failed_write_leaves_the_old_file(tmp_path, monkeypatch):
    p = atomic.write_text(tmp_path / "a.txt", "old")

    def broken(*a, **k):
        raise OSError("disk full")

    monkeypatch.setattr(os, "replace", broken)
    with pytest.raises(OSError):
        atomic.write_text(p, "new")
    assert p.read_text() == "old"
    assert [q.name for q in tmp_path.iterdir()] == ["a.txt"]
