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


def test_a_fault_point_fails_the_kth_write_as_a_full_disk(tmp_path, monkeypatch):
    """FALLGEN_FAULT=enospc:K: the K-th write of the process raises ENOSPC naming its file,
    and leaves neither a temporary nor a partial file; the old file stays."""
    import errno

    p = atomic.write_text(tmp_path / "a.txt", "old")
    monkeypatch.setenv(atomic.FAULT_ENV, "enospc:2")
    monkeypatch.setattr(atomic, "_WRITES", [0])
    atomic.write_text(tmp_path / "b.txt", "b")  # the first write
    with pytest.raises(OSError) as e:
        atomic.write_text(p, "new")
    assert e.value.errno == errno.ENOSPC and e.value.filename == str(p)
    tmp = tmp_path / "c.tmp"
    tmp.write_bytes(b"c")
    atomic.commit(tmp, tmp_path / "c.bin")  # the third: no fault
    assert p.read_text() == "old"
    assert sorted(q.name for q in tmp_path.iterdir()) == ["a.txt", "b.txt", "c.bin"]
    monkeypatch.setattr(atomic, "_WRITES", [0])
    monkeypatch.setenv(atomic.FAULT_ENV, "enospc:1")
    tmp.write_bytes(b"d")
    with pytest.raises(OSError):
        atomic.commit(tmp, tmp_path / "d.bin")
    assert not tmp.exists() and not (tmp_path / "d.bin").exists()


def test_a_write_error_names_its_file(tmp_path, monkeypatch):
    """A full disk reported without a file name (by a write, or by pyarrow's writer) is
    raised naming the file being written."""
    import errno

    e = atomic.named(OSError("Error writing bytes. Detail: [errno 28] No space left on device"),
                     tmp_path / "x")
    assert e.errno == errno.ENOSPC and e.filename == str(tmp_path / "x")
    real = os.fdopen

    class Full:
        def __init__(self, f):
            self.f = f

        def __enter__(self):
            return self

        def __exit__(self, *a):
            self.f.close()

        def fileno(self):
            return self.f.fileno()

        def write(self, data):
            raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(os, "fdopen", lambda fd, mode: Full(real(fd, mode)))
    with pytest.raises(OSError) as err:
        atomic.write_bytes(tmp_path / "y.bin", b"data")
    assert err.value.filename == str(tmp_path / "y.bin") and err.value.errno == errno.ENOSPC
    assert list(tmp_path.iterdir()) == []
