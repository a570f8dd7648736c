"""`fallgen validate` catches every injected corruption before a rerun of `fallgen build`, and
the rerun never certifies one: it makes the damaged files again (the dataset then validates and
is byte for byte the build it was) or refuses in one line (and validate still says why). Shards,
rehearsal files, manifest, card and write records: flipped, truncated, deleted, edited. Also
`validate` on a directory that mixes two builds, and its one-line errors."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

pytestmark = pytest.mark.xdist_group("tiny_build")

DIRS = ("data", "media", "rehearsal", ".")


def _flip(p: Path, at: int | None = None) -> None:
    b = bytearray(p.read_bytes())
    b[len(b) // 2 if at is None else at] ^= 0x40
    p.write_bytes(bytes(b))


def _audio_byte(p: Path) -> int:
    import h5py

    with h5py.File(p, "r") as f:
        return f["audio"].id.get_chunk_info(0).byte_offset + 1000


def _shards(root: Path) -> list[str]:
    d, m = root / "data", root / "media"
    h5 = m / "train-00000-of-00002.h5"
    _flip(h5, _audio_byte(h5))  # a flipped byte in an episode's audio
    t = m / "train-00001-of-00002.h5"
    t.write_bytes(t.read_bytes()[: t.stat().st_size // 2])  # truncated
    (m / "validation-00000-of-00002.h5").unlink()  # deleted (the rows still point at it)
    _flip(d / "validation-00001-of-00002.parquet")  # a flipped byte in the rows
    f = d / "test-00000-of-00002.parquet"
    f.write_bytes(f.read_bytes()[:-12] + b"\0" * 12)  # a broken footer: unreadable
    (d / "test-00001-of-00002.parquet").unlink()
    return ["media/train-00000-of-00002.h5", "media/train-00001-of-00002.h5",
            "media/validation-00000-of-00002.h5", "data/validation-00001-of-00002.parquet",
            "data/test-00000-of-00002.parquet", "data/test-00001-of-00002.parquet"]


def _rehearsal(root: Path) -> list[str]:
    r = root / "rehearsal"
    _flip(r / "kitchen_galley-l1-m1.parquet")
    side = r / "study_office-l1-m1.stats.json"
    d = json.loads(side.read_text())
    d["trials"] += 1  # edited, its checksum not
    side.write_text(json.dumps(d, indent=1, sort_keys=True))
    return ["rehearsal/kitchen_galley-l1-m1.parquet", "rehearsal/study_office-l1-m1.stats.json"]


def _manifest(root: Path) -> list[str]:
    m = json.loads((root / "manifest.json").read_text())
    m["episodes"]["train"] += 1
    m["files"]["data/test-00001-of-00002.parquet"]["sha256"] = "0" * 64
    (root / "manifest.json").write_text(json.dumps(m, indent=1, sort_keys=True))
    card = root / "README.md"
    card.write_text(card.read_text().replace("kitchen_to_study", "kitchen_to_kitchen"))
    return ["manifest.json", "data/test-00001-of-00002.parquet", "README.md"]


def _records(root: Path) -> list[str]:
    """The build's own write records (not the dataset's files: validate has nothing to say)."""
    recs = root / ".fallgen" / "shards"
    (recs / "train-00000-of-00002.json").unlink()
    r = recs / "test-00000-of-00002.json"
    r.write_text(r.read_text().replace('"bytes": ', '"bytes": 1', 1))
    return []


DAMAGE = {"shards": _shards, "rehearsal": _rehearsal, "manifest": _manifest,
          "records": _records}


@pytest.mark.parametrize("what", sorted(DAMAGE))
def test_validate_catches_it_and_a_rerun_repairs_it(tiny_build, tmp_path, cli, digest, what):
    from fallgen.dataset.validate import validate

    base, cfg = tiny_build
    root = tmp_path / "ds"
    shutil.copytree(base / "one", root)
    damaged = DAMAGE[what](root)
    problems = validate(root)
    for rel in damaged:
        assert any(str(root / rel) in p for p in problems), (rel, problems)
    assert all("\n" not in p for p in problems)
    assert cli("validate", str(root)) == (1 if damaged else 0)
    code = cli("build", "-c", str(cfg), "--out", str(root), "--workers", "1")
    if code == 0:  # made again: as it was, byte for byte
        assert validate(root) == []
        assert digest(root, DIRS) == digest(base / "one", DIRS)
    else:  # refused: the damage still shows
        assert code == 2 and validate(root)
    assert code == 0, what  # every one of these can be made again


def test_validate_sees_a_mixed_dataset_whatever_its_manifest_says(tiny_build, tmp_path):
    """Shards made from other events, or by another build, are named even when a manifest was
    written over them (the shards carry what made them)."""
    from fallgen.dataset.card import finalize
    from fallgen.dataset.manifest import read_manifest
    from fallgen.dataset.validate import validate

    base, _ = tiny_build
    root = tmp_path / "ds"
    shutil.copytree(base / "one", root)
    m = read_manifest(root)
    ev = root / "rehearsal" / "kitchen_galley-l1-m1.parquet"
    _flip(ev)
    other = dict(m["build"], fingerprint="0" * 20)
    finalize(root, m["config"], m["root_seed"], m["settings"], build=other)  # re-hashed
    problems = validate(root)
    assert any("made from other fall events than" in p and str(ev) in p for p in problems)
    assert any("made by another build than the manifest's" in p for p in problems)
    assert any(str(ev) in p and "sidecar" in p for p in problems)


def test_validate_names_two_shard_sets_of_a_split(tiny_build, tmp_path):
    from fallgen.dataset.validate import validate

    base, _ = tiny_build
    root = tmp_path / "ds"
    shutil.copytree(base / "one", root)
    for d, ext in (("data", "parquet"), ("media", "h5")):
        shutil.copy(root / d / f"train-00000-of-00002.{ext}",
                    root / d / f"train-00000-of-00001.{ext}")
    problems = validate(root)
    assert any("2 shard sets of train (of-00001, of-00002)" in p for p in problems)
    assert any("its metadata names another shard" in p for p in problems)


def test_validate_a_path_that_is_no_dataset_directory(tmp_path, cli, capsys):
    capsys.readouterr()
    assert cli("validate", str(tmp_path / "nonexistent")) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "nonexistent: <dir>: no such directory" in err
    f = tmp_path / "file"
    f.write_text("x")
    assert cli("validate", str(f)) == 2
    assert "a file, not a dataset directory" in capsys.readouterr().err


def test_unwritable_outputs_and_a_corrupt_footer_are_one_line(tiny_build, tmp_path, cli,
                                                              capsys):
    """`stats --json`, `show -o`, `evaluate -o` and `build` into a place that cannot be
    written, and `stats` on a shard whose Parquet footer is broken: one line, exit 2."""
    base, cfg = tiny_build
    blocker = tmp_path / "a-file"
    blocker.write_text("x")
    ds = str(base / "one")
    capsys.readouterr()
    for args in (("stats", ds, "--json", str(blocker / "s.json")),
                 ("show", ds, "0", "-o", str(blocker / "ep.png")),
                 ("evaluate", ds, "--episodes", "0", "--baseline", "expert", "--workers", "1",
                  "-o", str(blocker / "ev")),
                 ("build", "-c", str(cfg), "--out", str(blocker / "ds"))):
        assert cli(*args) == 2, args
        err = capsys.readouterr().err
        assert err.startswith("error: ") and err.count("\n") == 1 and str(blocker) in err, err
    root = tmp_path / "ds"
    shutil.copytree(base / "one", root)
    p = root / "data" / "train-00000-of-00002.parquet"
    p.write_bytes(p.read_bytes()[:-8] + b"\0" * 8)
    assert cli("stats", str(root)) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: ") and err.count("\n") == 1 and "Parquet" in err, err
