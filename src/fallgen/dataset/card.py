"""``DATASET/README.md``: the dataset card, written from the shards themselves.

Its YAML front matter declares Hugging Face ``configs``: ``default`` (train / validation / test)
and the two cross-scene configurations of the paper, ``kitchen_to_study`` (train and validate on
kitchens, test on study rooms) and ``study_to_kitchen``, each a list of whole shard files (every
shard holds one room kind). The body says what every field means, its unit, how the data was
made and how to cite it. Deterministic: the same shards give the same bytes.
"""

from __future__ import annotations

from collections import Counter
from pathlib import Path

import pyarrow.parquet as pq

from fallgen.atomic import write_text
from fallgen.config import CARD_HEAD, SPLITS
from fallgen.dataset.manifest import CARD, versions, write_manifest
from fallgen.dataset.schema import ARRAYS, COLUMNS

CROSS_SCENE = {"kitchen_to_study": ("kitchen", "study"), "study_to_kitchen": ("study", "kitchen")}

CITATION = """\
@inproceedings{gan2022finding,
  title     = {Finding Fallen Objects via Asynchronous Audio-Visual Integration},
  author    = {Gan, Chuang and Gu, Yi and Zhou, Siyuan and Schwartz, Jeremy and Alter, Seth and
               Traer, James and Gutfreund, Dan and Tenenbaum, Joshua B. and McDermott, Josh H.
               and Torralba, Antonio},
  booktitle = {IEEE/CVF Conference on Computer Vision and Pattern Recognition (CVPR)},
  year      = {2022},
  note      = {arXiv:2207.03483}
}"""


def _shard_rows(root: Path) -> list[tuple[str, list[dict]]]:
    """(file relative to root, its rows' split / room_kind / room_variant) per data shard."""
    cols = ["split", "room_kind", "room_variant"]
    return [(f"data/{p.name}", pq.read_table(p, columns=cols).to_pylist()
             if pq.read_metadata(p).num_rows else [])
            for p in sorted((root / "data").glob("*.parquet"))]


def shard_kinds(shards: list[tuple[str, list[dict]]]) -> dict[str, dict[str, list[str]]]:
    """split -> room kind -> shard files (sorted); raises ValueError for a shard that mixes
    room kinds."""
    out: dict[str, dict[str, list[str]]] = {}
    for f, rows in shards:
        kinds = {r["room_kind"] for r in rows}
        if len(kinds) > 1:
            raise ValueError(f"{f}: room_kind mixes {sorted(kinds)} (one kind per shard)")
        split = f.split("/")[-1].split("-")[0]
        for k in kinds:
            out.setdefault(split, {}).setdefault(k, []).append(f)
    return out


def _yaml_configs(files: dict[str, dict[str, list[str]]]) -> list[str]:
    lines = ["configs:", "- config_name: default", "  default: true", "  data_files:"]
    for split in SPLITS:
        if split in files:
            lines += [f"  - split: {split}", f"    path: data/{split}-*.parquet"]
    for name, (src, dst) in CROSS_SCENE.items():
        parts = [(s, files.get(s, {}).get(src if s != "test" else dst, [])) for s in SPLITS]
        parts = [(s, f) for s, f in parts if f]
        if not any(s == "test" for s, _ in parts) or not any(s == "train" for s, _ in parts):
            continue  # a build with one room kind has no cross-scene split
        lines += [f"- config_name: {name}", "  data_files:"]
        for split, fs in parts:
            lines += [f"  - split: {split}", "    path:"] + [f"    - {f}" for f in fs]
    return lines


def _table(head: list[str], rows: list[list]) -> list[str]:
    return (["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
            + ["| " + " | ".join(str(c) for c in r) + " |" for r in rows])


def write_card(root: Path, config_text: str, root_seed: int, versions: dict[str, str],
               settings: dict) -> Path:
    root = Path(root)
    shards = _shard_rows(root)
    files = shard_kinds(shards)
    rows = [r for _, rs in shards for r in rs]
    by = Counter((r["split"], r["room_kind"]) for r in rows)
    kinds = sorted({r["room_kind"] for r in rows})
    n = len(rows)
    g = settings.get("generate", {})
    lines = [*CARD_HEAD, "license: mit",
             "task_categories:", "- robotics", "tags:", "- embodied-ai", "- audio-visual",
             "- binaural", "- navigation", "- mujoco", "size_categories:",
             f"- {_size_category(n)}"]
    lines += _yaml_configs(files) + ["---", ""]
    lines += [
        "# Fallen Objects, made by fallgen", "",
        "A robot in a kitchen or a study room hears an unknown object fall somewhere in the room "
        "and must find what fell, and where, with its camera. Each episode holds the room "
        "variant, the fallen object and its fall and rest pose, the robot's spawn pose, "
        f"{g.get('audio_s', 2.0):g} s of binaural audio (44.1 kHz) of the fall heard at the "
        "robot's head (over a quiet home's noise floor of "
        f"{g.get('ambient_noise_db_a', 0.0):g} dB(A); every fall peaks at least "
        f"{g.get('min_heard_peak_db_spl', 0.0):g} dB SPL there: a quieter one starts no "
        "episode), the egocentric RGB, depth and "
        "segmentation (300 x 300, 90 degree field "
        "of view) at step 0, an occupancy map and a shortest-path expert trajectory. Success: "
        "`found` within 2 m of the object with the object in view (at least 4 segmentation "
        "pixels), in at most 200 actions. After Gan et al., CVPR 2022, rebuilt offline and "
        "deterministically.", "",
        "## Splits", "",
        f"{n} episodes in {len({r['room_variant'] for r in rows})} room variants. Each split is "
        "divided evenly between room kinds and every shard holds one kind, so the cross-scene "
        "configurations are sets of whole files. No fall event appears in two of train, "
        "validation and test.", ""]
    lines += _table(["split"] + kinds + ["total"],
                    [[s] + [by[(s, k)] for k in kinds] + [sum(by[(s, k)] for k in kinds)]
                     for s in SPLITS if any(by[(s, k)] for k in kinds)])
    lines += ["",
              "Configurations: `default` (train / validation / test); `kitchen_to_study` (train "
              "and validation on kitchens, test on study rooms) and `study_to_kitchen` (the "
              "reverse), the paper's cross-scene splits.", "",
              "## Loading", "",
              "```python",
              "import datasets  # rows only (Parquet); arrays are in media/*.h5",
              "rows = datasets.load_dataset(\"parquet\", data_files={\"train\": "
              "\"data/train-*.parquet\"})",
              "",
              "import fallgen.dataset  # rows with their arrays, as dicts of numpy arrays",
              "ds = fallgen.dataset.open(\".\")",
              "for ep in ds.episodes(\"test\"):",
              "    ep[\"audio\"], ep[\"rgb\"], ep[\"expert_actions\"]",
              "```", "",
              "Or with h5py alone: row `media_index` of the arrays in `media_file`.", "",
              "## Layout", "",
              "- `data/{split}-{i:05d}-of-{n:05d}.parquet`: one row per episode.",
              "- `media/{split}-{i:05d}-of-{n:05d}.h5`: the episodes' arrays, one chunk per "
              "episode (gzip, except the audio: float32 audio hardly compresses). "
              "Attributes: `actions` (names of the action indices), `category_labels` "
              "(names of the category segmentation values).",
              "- `rehearsal/*.parquet`: the fall events (start and rest state, every contact).",
              "- `manifest.json`: config, versions, root seed, counts, sha256 of every file; "
              "`fallgen validate .` checks them.", "",
              "Frames and units: room frame origin at the floor's south-west corner, x east, "
              "y north, z up, metres; quaternions (w, x, y, z); headings 0..11 in 30 degree "
              "steps counter-clockwise from +x; tilt in degrees, up positive.", "",
              "## Parquet columns", ""]
    lines += _table(["column", "type", "unit", "meaning"],
                    [[f"`{c}`", t, u, m.replace("|", "/")] for c, (t, u, m) in _columns()])
    lines += ["", "## HDF5 arrays", ""]
    lines += _table(["name", "shape", "dtype", "unit", "meaning"],
                    [[f"`{k}`", s, d, u, m] for k, (s, d, u, m) in ARRAYS.items()])
    lines += ["", "## How it was made", "",
              "1. Rehearsal: MuJoCo drops each object onto a fall zone from a random pose and "
              "keeps falls that settle inside the zone, recording every contact.",
              "2. Generation: each episode replays its fall with the robot standing at a "
              "random free spawn at least 2 m from the object, synthesises modal impact sound "
              "from the contacts (impact speed sets the loudness), spatialises it with "
              "image-source early reflections, the furniture's own first reflections, "
              "diffraction around furniture in the way, a late reverberation at the furnished "
              "room's RT60 (`room_rt60_s`) and an HRTF (" + _head(settings) + "), "
              "renders the first view with MuJoCo, and plans the expert over the robot's own "
              "action lattice, checked by replaying its actions.", "",
              f"Root seed {root_seed}; the episode's random generator is "
              "`numpy.random.SeedSequence(root_seed, spawn_key=(episode_id,))`, so every "
              "episode is reproducible on its own and the files do not depend on the number of "
              "workers. Versions:", ""]
    lines += [f"- {k} {v}" for k, v in sorted(versions.items())]
    cite = CITATION + ("\n\n" + SADIE_CITATION if _measured(settings) else "")
    lines += ["", "Build configuration:", "", "```toml", config_text.rstrip(), "```", "",
              "## Citation", "", "```bibtex", cite, "```", ""]
    return write_text(root / CARD, "\n".join(lines))


#: The measured head's database, to be cited with data made with it (its licence's README).
SADIE_CITATION = """@inproceedings{kearney2015sadie,
  title     = {A {HRTF} database for virtual loudspeaker rendering},
  author    = {Kearney, Gavin and Doyle, Tony},
  booktitle = {Audio Engineering Society Convention 139},
  year      = {2015}
}"""


def _measured(settings: dict) -> bool:
    return settings.get("generate", {}).get("hrtf") == "sadie_ku100"


def _head(settings: dict) -> str:
    spec = settings.get("generate", {}).get("hrtf", "")
    if spec == "sadie_ku100":
        return "the SADIE database's Neumann KU100 dummy head, measured, Apache-2.0: cite it"
    if spec in ("", "sphere"):
        return "Brown & Duda's spherical-head model"
    return f"the SOFA file `{spec}`"


def finalize(root: Path, config_text: str, root_seed: int, settings: dict,
             build: dict | None = None, hash_of=None) -> Path:
    """Once every shard exists: the dataset card, then the manifest (which lists the card)."""
    write_card(root, config_text, root_seed, versions(), settings)
    return write_manifest(root, config_text, root_seed, settings, build, hash_of)


def target_categories() -> int:
    """How many target categories the world data defines (every ``objects/*.toml`` table with
    ``role = "target"``; ``$FALLGEN_DATA`` or the built-in data)."""
    import tomllib

    from fallgen.paths import data_root

    n = 0
    for f in sorted((data_root() / "objects").glob("*.toml")):
        with open(f, "rb") as fh:
            n += sum(isinstance(c, dict) and c.get("role") == "target"
                     for c in tomllib.load(fh).values())
    return n


def _columns() -> list[tuple[str, tuple[str, str, str]]]:
    """The Parquet columns of the schema, the category's count of the world data."""
    return [(c, (t, u, f"object category (one of {target_categories()} target categories)"
                 if c == "category" else m)) for c, (t, u, m) in COLUMNS.items()]


def _size_category(n: int) -> str:
    for lim, name in ((1_000, "n<1K"), (10_000, "1K<n<10K"), (100_000, "10K<n<100K")):
        if n < lim:
            return name
    return "100K<n<1M"


__all__ = ["write_card", "finalize", "shard_kinds", "target_categories", "CARD", "CROSS_SCENE"]
