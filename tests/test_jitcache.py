"""Compiled code is cached per version of the package's sources (fallgen.jitcache): a function
whose cached code read a constant of another module sees that constant's new value once the
other module changes, where Numba's own cache (keyed by the function's file alone) keeps the
old one."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import fallgen
from fallgen import jitcache

#: a package of two modules: ``limits`` holds a constant, ``proof`` compiles a function (cached)
#: that reads it, as vision/region.py reads vision/sight.py's MARGIN
PROOF = textwrap.dedent("""
    from numba import njit
    from pkg.limits import MARGIN

    @njit(cache=True)
    def margin():
        return MARGIN
""")


def _package(root: Path, margin: float) -> Path:
    pkg = root / "pkg"
    pkg.mkdir(exist_ok=True)
    (pkg / "__init__.py").write_text("")
    (pkg / "limits.py").write_text(f"MARGIN = {margin!r}\n")
    if not (pkg / "proof.py").exists():  # written once: its file (and Numba's key) unchanged
        (pkg / "proof.py").write_text(PROOF)
    return pkg


def _margin(root: Path, cache: Path | None) -> float:
    """What the cached function returns in a fresh process (cache: Numba's cache directory;
    None: beside the sources, Numba's default)."""
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"}
    if cache is not None:
        env["NUMBA_CACHE_DIR"] = str(cache)
    out = subprocess.run([sys.executable, "-c", "from pkg.proof import margin; print(margin())"],
                         cwd=root, env=env, capture_output=True, text=True, check=True)
    return float(out.stdout)


def test_a_constant_changed_in_another_module_is_seen_through_the_versioned_cache(tmp_path):
    """Numba's own cache keeps the constant the function was first compiled with; the cache
    directory named by the package's sources gives the new one."""
    own, versioned = tmp_path / "own", tmp_path / "versioned"
    for root in (own, versioned):
        root.mkdir()
        _package(root, 1e-3)
    caches = tmp_path / "caches"
    assert _margin(own, None) == 1e-3
    assert _margin(versioned, jitcache.cache_dir(versioned / "pkg", caches)) == 1e-3
    for root in (own, versioned):
        _package(root, 2e-4)
    assert _margin(own, None) == 1e-3  # stale: what the versioned directory prevents
    assert _margin(versioned, jitcache.cache_dir(versioned / "pkg", caches)) == 2e-4


def test_the_directory_changes_with_any_source_file(tmp_path):
    """One byte of any module, or a module added, names another directory."""
    pkg = _package(tmp_path, 1e-3)
    a = jitcache.source_digest(pkg)
    assert jitcache.source_digest(pkg) == a
    (pkg / "limits.py").write_text("MARGIN = 0.001 \n")
    b = jitcache.source_digest(pkg)
    (pkg / "extra.py").write_text("")
    c = jitcache.source_digest(pkg)
    assert len({a, b, c}) == 3


def test_the_same_sources_elsewhere_name_another_directory(tmp_path):
    """Numba keys compiled code by its file's full path: a second checkout of the same sources
    gets its own directory and mark (a mark shared with the first would skip compiling ahead
    where nothing is compiled)."""
    a, b = tmp_path / "a", tmp_path / "b"
    a.mkdir()
    b.mkdir()
    assert jitcache.source_digest(_package(a, 1e-3)) != jitcache.source_digest(_package(b, 1e-3))
    assert jitcache.source_digest(_package(a, 1e-3)) == jitcache.source_digest(a / "pkg")


def test_fallgen_points_numba_at_its_sources_directory():
    """Importing fallgen set Numba's cache directory (unless the user had): the directory of
    fallgen's own sources under the fallgen cache."""
    from fallgen.cache import cache_root

    here = jitcache.cache_dir(Path(fallgen.__file__).resolve().parent, cache_root())
    if os.environ.get("NUMBA_CACHE_DIR") != str(here):  # the user's choice, left alone
        assert jitcache.configure() is None
        return
    import numba

    assert numba.core.config.CACHE_DIR == str(here)


def test_a_cache_that_cannot_be_written_is_left_to_numba(tmp_path, monkeypatch):
    """$FALLGEN_CACHE under a file (no directory can be made there, whoever runs): the
    environment is left as it was and configure says so."""
    blocker = tmp_path / "file"
    blocker.write_text("")
    monkeypatch.setenv("FALLGEN_CACHE", str(blocker / "cache"))
    monkeypatch.delenv("NUMBA_CACHE_DIR", raising=False)
    assert jitcache.configure(_package(tmp_path, 1e-3)) is None
    assert "NUMBA_CACHE_DIR" not in os.environ


def test_a_new_version_removes_directories_unused_for_a_week(tmp_path, monkeypatch):
    """A first run of new sources removes the other versions' directories untouched for
    KEEP_S, and keeps the recent ones."""
    import numba

    monkeypatch.setenv("FALLGEN_CACHE", str(tmp_path / "cache"))
    monkeypatch.delenv("NUMBA_CACHE_DIR", raising=False)
    monkeypatch.setattr(numba.core.config, "CACHE_DIR", numba.core.config.CACHE_DIR)
    old, recent = tmp_path / "cache" / "numba" / "old", tmp_path / "cache" / "numba" / "recent"
    for d in (old, recent):
        d.mkdir(parents=True)
    week_ago = time.time() - jitcache.KEEP_S - 60
    os.utime(old, (week_ago, week_ago))
    here = jitcache.configure(_package(tmp_path, 1e-3))
    assert here is not None and here.is_dir() and os.environ["NUMBA_CACHE_DIR"] == str(here)
    assert not old.exists() and recent.exists()


def test_the_mark_of_compiled_code_is_named_by_the_sources(tmp_path, monkeypatch):
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path))
    pkg = _package(tmp_path, 1e-3)
    first = jitcache.done_marker("compiled", pkg)
    _package(tmp_path, 2e-4)
    assert first.parent == tmp_path and jitcache.done_marker("compiled", pkg) != first
    monkeypatch.delenv("NUMBA_CACHE_DIR")
    assert jitcache.done_marker("compiled", pkg) is None
