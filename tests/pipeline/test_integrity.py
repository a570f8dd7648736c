"""Builds never lie (tiny_build fixture, tests/conftest.py): a changed config, world, code or
split size, a --force rehearsal, a killed or out-of-space build each end with a dataset that
validates and is byte for byte a clean build of what the config says, or with a one-line
refusal (exit 2); one writer per directory."""

from __future__ import annotations

import json
import os
import random
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

pytestmark = pytest.mark.xdist_group("tiny_build")

#: what a build's bytes are compared on: shards, rehearsal, card and manifest
DIRS = ("data", "media", "rehearsal", ".")


def _copy(base: Path, dst: Path) -> Path:
    """The tiny build (with its write records), to change."""
    shutil.copytree(base / "one", dst)
    return dst


def _edit(cfg: Path, dst: Path, old: str, new: str) -> Path:
    text = cfg.read_text()
    assert old in text, old
    dst.write_text(text.replace(old, new))
    return dst


def _clean_build(cli, cfg: Path, dst: Path, rehearsal: Path | None = None) -> Path:
    """``cfg`` built into an empty ``dst`` (its rehearsal copied from ``rehearsal``, made by
    the same [rehearse] section: a variant's rehearsal is the same bytes wherever and however
    often it is made, tests/physics/test_rehearse.py)."""
    dst.mkdir()
    if rehearsal is not None:
        shutil.copytree(rehearsal, dst / "rehearsal")
    assert cli("build", "-c", str(cfg), "--out", str(dst), "--workers", "1") == 0
    return dst


def _one_line(err: str) -> str:
    assert err.startswith("error: ") and err.count("\n") == 1, err
    return err


def test_a_generate_change_makes_the_shards_again(tiny_build, tmp_path, cli, digest, capsys):
    """[generate] ambient_noise_db_a 30 -> 50 over a finished build: every shard is made again
    (its fingerprint has the config's values), the rows, card and manifest all say 50, and the
    bytes are a clean build's of the new config."""
    import fallgen.dataset

    base, cfg = tiny_build
    loud = _edit(cfg, tmp_path / "loud.toml", "ambient_noise_db_a = 30.0",
                 "ambient_noise_db_a = 50.0")
    root = _copy(base, tmp_path / "ds")
    capsys.readouterr()
    assert cli("build", "-c", str(loud), "--out", str(root), "--workers", "1") == 0
    out = capsys.readouterr().out
    assert "made again" in out and "ambient_noise_db_a 30.0 -> 50.0" in out
    rows = fallgen.dataset.open(root).rows()
    assert len(rows) == 6 and all(r["audio_noise_db_a"] == pytest.approx(50.0, abs=0.5)
                                  for r in rows)
    m = json.loads((root / "manifest.json").read_text())
    assert m["settings"]["generate"]["ambient_noise_db_a"] == 50.0
    assert "50 dB(A)" in (root / "README.md").read_text()
    assert cli("validate", str(root)) == 0
    clean = _clean_build(cli, loud, tmp_path / "clean", base / "one" / "rehearsal")
    assert digest(root, DIRS) == digest(clean, DIRS)


def test_generate_refuses_events_rehearsed_in_another_world(tiny_build, tmp_path, data_copy,
                                                            cli, capsys):
    """Shards deleted, a material constant changed (--data-dir): `generate` checks the
    rehearsal as `build` does and refuses in one line naming the file and what changed,
    before making anything."""
    base, cfg = tiny_build
    root = _copy(base, tmp_path / "ds")
    gone = [root / "data" / "train-00001-of-00002.parquet",
            root / "media" / "train-00001-of-00002.h5"]
    for p in gone:
        p.unlink()
    objects = data_copy / "materials" / "objects.toml"
    objects.write_text(objects.read_text().replace("density_kg_m3 = 7850",
                                                   "density_kg_m3 = 7900", 1))
    capsys.readouterr()
    assert cli("generate", "-c", str(cfg), "--out", str(root), "--workers", "1",
               "--data-dir", str(data_copy)) == 2
    err = _one_line(capsys.readouterr().err)
    assert ".stats.json: fingerprint: rehearsed under another" in err
    assert "world.materials changed" in err
    assert not any(p.exists() for p in gone)
    assert cli("validate", str(root)) == 1


def test_rehearse_force_makes_the_shards_of_the_old_events_again(tiny_build, tmp_path, cli,
                                                                  digest, capsys):
    """min_fall_m 0.3 -> 0.35: `build` refuses the old rehearsal (one line); `rehearse --force`
    makes the directory an unfinished build (no manifest); the next `build` makes again the
    shards whose events changed (the kitchen's), keeps the others, and ends as a clean build
    of the new config."""
    base, cfg = tiny_build
    new = _edit(cfg, tmp_path / "new.toml", "min_fall_m = 0.3 ", "min_fall_m = 0.35 ")
    root = _copy(base, tmp_path / "ds")
    capsys.readouterr()
    assert cli("build", "-c", str(new), "--out", str(root), "--workers", "1") == 2
    err = _one_line(capsys.readouterr().err)
    assert "config.rehearse.min_fall_m 0.3 -> 0.35" in err and "--force" in err
    assert cli("rehearse", "-c", str(new), "--out", str(root), "--workers", "1",
               "--force") == 0
    assert not (root / "manifest.json").exists() and not (root / "README.md").exists()
    assert cli("validate", str(root)) == 1
    capsys.readouterr()
    assert cli("build", "-c", str(new), "--out", str(root), "--workers", "1") == 0
    out = capsys.readouterr().out
    assert "events.kitchen_galley-l1-m1 changed" in out
    assert cli("validate", str(root)) == 0
    old, now = digest(base / "one"), digest(root)
    kitchen = {k for k in now if "-00000-" in k}  # kitchens first in every split
    assert all(now[k] != old[k] for k in kitchen)
    assert all(now[k] == old[k] for k in set(now) - kitchen)  # study: the same events
    clean = _clean_build(cli, new, tmp_path / "clean", root / "rehearsal")
    assert digest(root, DIRS) == digest(clean, DIRS)


def test_a_new_split_size_replaces_the_shard_set(tiny_build, tmp_path, cli, digest, capsys):
    """train 2 -> 1: the old train-*-of-00002 set is removed (not left beside of-00001), the
    validation and test shards whose episode ids moved are made again; manifest, loader and
    validate agree, and the bytes are a clean build's."""
    import fallgen.dataset

    base, cfg = tiny_build
    new = _edit(cfg, tmp_path / "new.toml", "train = 2,", "train = 1,")
    root = _copy(base, tmp_path / "ds")
    capsys.readouterr()
    assert cli("build", "-c", str(new), "--out", str(root), "--workers", "1") == 0
    assert "removed 2 shards of another plan" in capsys.readouterr().out
    names = sorted(p.name for d in ("data", "media") for p in (root / d).glob("train-*"))
    assert names == ["train-00000-of-00001.h5", "train-00000-of-00001.parquet"]
    m = json.loads((root / "manifest.json").read_text())
    assert sum(m["episodes"].values()) == len(fallgen.dataset.open(root)) == 5
    assert cli("validate", str(root)) == 0
    clean = _clean_build(cli, new, tmp_path / "clean", base / "one" / "rehearsal")
    assert digest(root, DIRS) == digest(clean, DIRS)


def test_finalize_lists_only_shards_that_check(tiny_build, tmp_path, cli, capsys):
    """`finalize` checks every shard against its write record before the manifest lists it:
    a shard changed since is named (exit 2) and the directory is no finished build; a file
    that is not a shard of the build is refused, not listed."""
    base, cfg = tiny_build
    root = _copy(base, tmp_path / "ds")
    p = root / "media" / "test-00001-of-00002.h5"
    p.write_bytes(p.read_bytes()[:-10])
    capsys.readouterr()
    assert cli("finalize", "-c", str(cfg), "--out", str(root)) == 2
    err = _one_line(capsys.readouterr().err)
    assert "test-00001-of-00002 (corrupt: media/test-00001-of-00002.h5 is" in err
    assert not (root / "manifest.json").exists()
    shutil.copy(base / "one" / "media" / p.name, p)
    (root / "data" / "notes.txt").write_text("mine")
    assert cli("finalize", "-c", str(cfg), "--out", str(root)) == 2
    assert "notes.txt: <file>: not a file of this build" in capsys.readouterr().err
    (root / "data" / "notes.txt").unlink()
    assert cli("finalize", "-c", str(cfg), "--out", str(root)) == 0
    assert cli("validate", str(root)) == 0


def test_one_writer_per_directory(tiny_build, tmp_path, cli, capsys):
    """A second writer gets one line naming the holder (pid, host) and exit 2; the lock goes
    with its holder. Temporary names are the writer's own."""
    from fallgen.dataset.writer import ShardWriter

    base, cfg = tiny_build
    root = _copy(base, tmp_path / "ds")
    code = ("import sys, time\nfrom pathlib import Path\n"
            "from fallgen.dataset.integrity import writer_lock\n"
            "with writer_lock(Path(sys.argv[1])):\n"
            "    print('held', flush=True)\n    time.sleep(60)\n")
    holder = subprocess.Popen([sys.executable, "-c", code, str(root)], stdout=subprocess.PIPE,
                              text=True)
    try:
        assert holder.stdout.readline().strip() == "held"
        capsys.readouterr()
        for cmd in ("build", "generate"):
            assert cli(cmd, "-c", str(cfg), "--out", str(root)) == 2
            err = _one_line(capsys.readouterr().err)
            assert f"lock: another fallgen is writing this directory (pid {holder.pid} on" in err
    finally:
        holder.kill()
        holder.wait()
    assert cli("finalize", "-c", str(cfg), "--out", str(root)) == 0
    a = ShardWriter(tmp_path / "w", "train", 0, 1, ("x",))
    b = ShardWriter(tmp_path / "w", "train", 0, 1, ("x",))
    assert a._tmp != b._tmp and a._tmp.exists() and b._tmp.exists()
    assert str(os.getpid()) in a._tmp.name and a._tmp.name.startswith(".")
    a.abort()
    b.abort()
    assert sorted(p.name for p in (tmp_path / "w").rglob("*")) == ["data", "media"]


def _whole(root: Path) -> None:
    """Every file under a final name is complete, and a shard's rows never sit without their
    media file."""
    import h5py
    import pyarrow.parquet as pq

    for p in (root / "data").glob("*.parquet"):
        pq.read_table(p)
        assert (root / "media" / p.name.replace(".parquet", ".h5")).exists()
    for p in (root / "media").glob("*.h5"):
        with h5py.File(p, "r") as f:
            assert "audio" in f
    for p in (root / "rehearsal").glob("*.parquet"):
        pq.read_table(p)
        assert p.with_suffix(".stats.json").exists()


@pytest.mark.slow  # five `fallgen build` processes: ~30 s
def test_a_build_killed_at_seeded_points_then_rerun_gives_the_same_bytes(tiny_build, tmp_path,
                                                                         cli, digest):
    """`fallgen build` processes end at seeded write points (FALLGEN_FAULT=exit:K: os._exit at
    the K-th write of the process, as kill -9 would: in the rehearsal of a variant, in a
    shard's episodes, between a shard's media and rows, in the card or manifest); after each,
    nothing partial sits under a final name, and a rerun ends with the bytes of an
    uninterrupted build."""
    base, cfg = tiny_build
    root = tmp_path / "ds"
    shutil.copytree(base / "one" / "rehearsal", root / "rehearsal")
    for p in root.glob("rehearsal/study_office-*"):
        p.unlink()  # the build rehearses it: kill points in the rehearsal too
    env = {k: v for k, v in os.environ.items() if k != "FALLGEN_FAULT"}
    cmd = [sys.executable, "-m", "fallgen", "build", "-c", str(cfg), "--out", str(root),
           "--workers", "1"]
    rng = random.Random(2041)  # kills in: a rehearsal sidecar, a shard's media rename, an
    points = []                # episode, a write record, a shard's rows rename
    for _ in range(5):
        k = rng.randint(1, 9)
        r = subprocess.run(cmd, env={**env, "FALLGEN_FAULT": f"exit:{k}"},
                           capture_output=True, text=True)
        points.append((k, r.returncode))
        assert r.returncode in (0, 137), (points, r.stderr[-2000:])
        _whole(root)
    assert all(c == 137 for _, c in points), points  # each killed
    assert cli("build", "-c", str(cfg), "--out", str(root), "--workers", "1") == 0, points
    assert digest(root, DIRS) == digest(base / "one", DIRS), points
    assert not list(root.rglob("*.tmp"))
    assert cli("validate", str(root)) == 0


@pytest.mark.parametrize("k", [5, 7])  # a shard's episode (its HDF5 flush), its write record
def test_a_full_disk_ends_in_one_line_and_a_rerun_completes(tiny_build, tmp_path, cli, digest,
                                                            capsys, monkeypatch, k):
    """ENOSPC at a write point (FALLGEN_FAULT=enospc:K) of the second shard made: one line,
    exit 2, no temporary file and no shard half there; once there is space the rerun
    completes with the same bytes."""
    from fallgen import atomic
    from fallgen.config import load_config
    from fallgen.pipeline.generate import build_plan, making_order

    base, cfg = tiny_build
    root = tmp_path / "ds"
    shutil.copytree(base / "one" / "rehearsal", root / "rehearsal")
    first, second = [j.name for j in making_order(build_plan(load_config(cfg), root).jobs)][:2]
    monkeypatch.setenv("FALLGEN_FAULT", f"enospc:{k}")
    monkeypatch.setattr(atomic, "_WRITES", [0])
    capsys.readouterr()
    assert cli("build", "-c", str(cfg), "--out", str(root), "--workers", "1") == 2
    err = _one_line(capsys.readouterr().err)
    assert "no space left on device" in err and second in err
    assert not [p for p in root.rglob("*") if p.name.endswith(".tmp")]
    made = sorted(p.stem for p in (root / "data").glob("*.parquet"))
    assert made == [first]
    assert sorted(p.stem for p in (root / "media").glob("*.h5")) == made
    monkeypatch.delenv("FALLGEN_FAULT")
    assert cli("build", "-c", str(cfg), "--out", str(root), "--workers", "1") == 0
    assert digest(root, DIRS) == digest(base / "one", DIRS)


def test_a_corrupt_modal_cache_entry_is_solved_again(tmp_path):
    """A damaged .npz in the modal cache (a flipped byte: BadZipFile) is recomputed, as
    docs/dataset.md says, not a crash of every build."""
    import numpy as np
    import trimesh

    from fallgen.audio.modes import ModalSettings, cache_path, modal_model

    box = trimesh.creation.box((0.05, 0.04, 0.03))
    v, f = np.asarray(box.vertices), np.asarray(box.faces)
    s = ModalSettings(target_voxels=200, n_modes=6)
    first = modal_model(v, f, 0.3, s, cache_dir=tmp_path)
    path = cache_path(v, f, 0.3, s, tmp_path)
    b = bytearray(path.read_bytes())
    b[len(b) // 2] ^= 0xFF
    path.write_bytes(bytes(b))
    again = modal_model(v, f, 0.3, s, cache_dir=tmp_path)
    assert np.array_equal(again.omega, first.omega)
    path.write_bytes(b"PK\x03\x04 not a zip")
    assert np.array_equal(modal_model(v, f, 0.3, s, cache_dir=tmp_path).omega, first.omega)
