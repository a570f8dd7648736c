"""Compiled code is cached per version of the package's sources (fallgen.jitcache): a function
whose cached code read a constant of another module sees that constant's new value once the
other module changes, where Numba's own cache (keyed by the function's file alone) keeps the
old one."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
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
