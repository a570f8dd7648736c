"""``fallgen validate DATASET``: everything a user should be able to trust, checked.

Checksums and sizes against the manifest (a flipped byte, a truncated or missing file, an extra
shard), the shard set (every ``i-of-n`` present, one set per split), Parquet schemas and row
counts per split, the HDF5 media (opens, shapes, dtypes, audio length and rate, finite values,
one media row per episode), episode ids unique and contiguous, no fall event in two of train /
validation / test, and every episode's fall event present in the rehearsal files. Then what
made the files, without trusting the manifest's checksums alone: every shard carries the
build's fingerprint (the manifest's ``build``), the sha256 of its media file and of the
rehearsal files it replays, and its media file its fingerprint; every rehearsal file's sidecar
records its sha256. Returns a list of problems, each one line naming the file; a path that is
not a directory is an InputError.
"""

from __future__ import annotations

import glob
import json
import re
from pathlib import Path

import h5py
import numpy as np
import pyarrow.parquet as pq

from fallgen.config import SPLITS
from fallgen.dataset.integrity import read_json
from fallgen.dataset.manifest import MANIFEST, listed_files, sha256
from fallgen.errors import InputError
from fallgen.dataset.schema import REQUIRED
from fallgen.dataset.writer import shard_meta

SHARD = re.compile(r"^(?P<split>[a-z_]+)-(?P<i>\d{5})-of-(?P<n>\d{5})\.(parquet|h5)$")


def validate(root: str | Path) -> list[str]:
    root = Path(root)
    if not root.is_dir():
        raise InputError(root, "<dir>", "no such directory" if not root.exists() else
                         "a file, not a dataset directory")
    problems: list[str] = []
    man_path = root / MANIFEST
    try:
        manifest = json.loads(man_path.read_text())
        files = manifest["files"]
        audio_s = float(manifest["settings"]["generate"]["audio_s"])
    except FileNotFoundError:
        return [f"{man_path}: missing (the build did not finish)"]
    except (ValueError, KeyError, TypeError) as e:
        return [f"{man_path}: unreadable manifest ({e})"]

    # files vs manifest
    present = {str(p.relative_to(root)) for p in listed_files(root)}
    for rel in sorted(set(files) - present):
        problems.append(f"{root / rel}: listed in the manifest but missing")
    for rel in sorted(present - set(files)):
        problems.append(f"{root / rel}: not in the manifest")
    hashes: dict[str, str] = {}
    for rel in sorted(present):
        p = root / rel
        hashes[rel] = sha256(p)
        if rel not in files:
            continue
        if p.stat().st_size != files[rel]["bytes"]:
            problems.append(f"{p}: {p.stat().st_size} bytes, manifest says {files[rel]['bytes']}")
        elif hashes[rel] != files[rel]["sha256"]:
            problems.append(f"{p}: checksum differs from the manifest")

    # shard sets
    shards: dict[tuple[str, str], set[int]] = {}
    for rel in present:
        m = SHARD.match(Path(rel).name)
        if rel.startswith(("data/", "media/")):
            if not m:
                problems.append(f"{root / rel}: not a shard name")
                continue
            shards.setdefault((rel.split("/")[0], m["split"] + "/" + m["n"]), set()).add(int(m["i"]))
    for (d, key), got in sorted(shards.items()):
        n = int(key.split("/")[1])
        for i in sorted(set(range(n)) - got):
            problems.append(f"{root / d}/{key.split('/')[0]}-{i:05d}-of-{n:05d}: shard missing")
    sets: dict[tuple[str, str], list[str]] = {}
    for d, key in shards:
        sets.setdefault((d, key.split("/")[0]), []).append(key.split("/")[1])
    for (d, split), ns in sorted(sets.items()):
        if len(ns) > 1:
            problems.append(f"{root / d}: {len(ns)} shard sets of {split} (of-"
                            f"{', of-'.join(sorted(ns))}): one build has one")
    problems += _check_rehearsal(root, hashes)
    build = (manifest.get("build") or {}).get("fingerprint")

    # rows, media, events
    events = set()
    for f in sorted(glob.glob(str(root / "rehearsal" / "*.parquet"))):
        try:
            events |= set(pq.read_table(f, columns=["event_id"]).column(0).to_pylist())
        except Exception as e:  # a broken Parquet file raises several types
            problems.append(f"{f}: unreadable ({type(e).__name__})")
    ids, dropped, by_split, per_split = [], [], {}, {}
    for p in sorted((root / "data").glob("*.parquet")):
        try:
            t = pq.read_table(p)
        except Exception as e:
            problems.append(f"{p}: unreadable Parquet ({type(e).__name__})")
            continue
        missing = [c for c in REQUIRED if c not in t.column_names]
        if missing and t.num_rows:
            problems.append(f"{p}: missing columns {', '.join(missing)}")
            continue
        try:
            meta = shard_meta(t.schema)
            dropped += [d[0] for d in meta["dropped"]]
        except (KeyError, ValueError, TypeError, IndexError):
            problems.append(f"{p}: no fallgen metadata (split, shard, dropped episodes)")
        else:
            problems += _check_made(root, p, meta, build, hashes)
        rows = t.to_pylist()
        if len({r["room_kind"] for r in rows}) > 1:
            problems.append(f"{p}: mixes room kinds (one per shard)")
        split = p.name.split("-")[0]
        per_split[split] = per_split.get(split, 0) + len(rows)
        media: dict[str, list[dict]] = {}
        for r in rows:
            ids.append(r["episode_id"])
            if r["split"] != split:
                problems.append(f"{p}: episode {r['episode_id']} has split {r['split']!r}")
            by_split.setdefault(r["split"], set()).add(r["event_id"])
            if events and r["event_id"] not in events:
                problems.append(f"{p}: episode {r['episode_id']}: fall event {r['event_id']} "
                                "not in rehearsal/")
            media.setdefault(r["media_file"], []).append(r)
        for rel, rs in media.items():
            problems += _check_media(root / rel, rs, audio_s)
    counts = manifest.get("episodes", {})
    for split in sorted(set(counts) | set(per_split)):
        if counts.get(split, 0) != per_split.get(split, 0):
            problems.append(f"{man_path}: {split} has {per_split.get(split, 0)} episodes, "
                            f"manifest says {counts.get(split, 0)}")
    if len(set(ids)) != len(ids) or set(ids) & set(dropped):
        problems.append(f"{root / 'data'}: episode ids are not unique")
    elif sorted(ids + dropped) != list(range(len(ids) + len(dropped))):
        problems.append(f"{root / 'data'}: episode ids (with the dropped ones) are not "
                        "contiguous from 0")
    main = [s for s in SPLITS if s in by_split]
    for a in range(len(main)):
        for b in range(a + 1, len(main)):
            both = by_split[main[a]] & by_split[main[b]]
            if both:
                problems.append(f"{root / 'data'}: {len(both)} fall events in both {main[a]} "
                                f"and {main[b]} (e.g. {sorted(both)[0]})")
    return problems


def _check_rehearsal(root: Path, hashes: dict[str, str]) -> list[str]:
    """Each rehearsal file against its sidecar (its own checksum, the file's sha256)."""
    out = []
    for rel in sorted(h for h in hashes if h.startswith("rehearsal/") and h.endswith(".parquet")):
        side = (root / rel).with_suffix(".stats.json")
        rec = read_json(side)
        if rec is None:
            out.append(f"{side}: missing, unreadable or edited (its checksum differs)")
        elif (rec.get("parquet") or {}).get("sha256") != hashes[rel]:
            out.append(f"{root / rel}: not the file its sidecar records (changed since it was "
                       "written)")
    return out


def _check_made(root: Path, p: Path, meta: dict, build: str | None,
                hashes: dict[str, str]) -> list[str]:
    """What made a shard, from its own metadata: the build's fingerprint, its media file's
    sha256 and fingerprint, the rehearsal files it replays, its name."""
    out = []
    m = SHARD.match(p.name)
    if m and (meta.get("split"), meta.get("shard"), meta.get("num_shards")) != \
            (m["split"], int(m["i"]), int(m["n"])):
        out.append(f"{p}: its metadata names another shard")
    if "fingerprint" not in meta:
        return out + [f"{p}: no fingerprint (not made by this fallgen's build)"]
    if build is None or meta.get("build") != build:
        out.append(f"{p}: made by another build than the manifest's (fingerprint "
                   f"{meta.get('build')}, manifest {build})")
    media = f"media/{p.stem}.h5"
    if media in hashes and meta.get("media_sha256") != hashes[media]:
        out.append(f"{root / media}: not the media file its shard was written with")
    for variant, sha in sorted((meta.get("events") or {}).items()):
        rel = f"rehearsal/{variant}.parquet"
        if rel in hashes and hashes[rel][:len(sha)] != sha:
            out.append(f"{p}: made from other fall events than {root / rel} holds now")
    if media in hashes:
        try:
            with h5py.File(root / media, "r") as f:
                if f.attrs.get("fingerprint") != meta["fingerprint"]:
                    out.append(f"{root / media}: its fingerprint is not its shard's")
        except OSError:
            pass  # reported as unreadable below
    return out


def _check_media(path: Path, rows: list[dict], audio_s: float) -> list[str]:
    out: list[str] = []
    try:
        with h5py.File(path, "r") as f:
            n = len(rows)
            rate = rows[0]["sample_rate"]
            want = {"audio": ((n, 2, int(round(audio_s * rate))), np.float32),
                    "rgb": ((n, 300, 300, 3), np.uint8), "depth": ((n, 300, 300), np.float16),
                    "instance": ((n, 300, 300), np.int16), "category": ((n, 300, 300), np.int16)}
            for name, (shape, dtype) in want.items():
                if name not in f:
                    out.append(f"{path}: dataset {name} missing")
                    continue
                d = f[name]
                if d.shape != shape or d.dtype != dtype:
                    out.append(f"{path}: {name} is {d.shape} {d.dtype}, expected {shape} "
                               f"{np.dtype(dtype)}")
                    continue
                if name in ("audio", "depth"):
                    for k in range(n):
                        if not np.isfinite(d[k]).all():
                            out.append(f"{path}: {name}[{k}] has non-finite values")
            if sorted(r["media_index"] for r in rows) != list(range(n)):
                out.append(f"{path}: media rows do not match the episodes that point to it")
            occ = f.get("occupancy")
            if occ is None or len(occ) != n:
                out.append(f"{path}: occupancy maps missing")
    except (OSError, KeyError, ValueError) as e:
        out.append(f"{path}: unreadable HDF5 ({type(e).__name__}: {str(e)[:80]})")
    return out
