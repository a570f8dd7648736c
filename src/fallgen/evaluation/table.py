"""``fallgen table`` (``make table``): the paper's Table 1 and Table 2 on a build, with the learned
audio and visual modules in the modular agent.

1. The audio module (:mod:`fallgen.perception.audio_model`) is trained on the build's train
   split three times: on every room (Table 1), on the kitchens alone and on the study rooms
   alone (Table 2); each is scored on the test episodes it is used on. The visual module
   (:mod:`fallgen.learn.vision_model`, with torch: ``fallgen[learn]``) is trained once on the
   train split and scored on Table 1's test episodes' frames.
2. Agents run on the test split (a seeded subsample of ``episodes`` when it is larger):
   random, Object-Goal (the visual module, five candidate categories, no audio), the modular
   agent with the learned modules and the paper's oracle ablations (each row with the same
   kind of modules as the paper's: learned audio wherever the category or the place is not
   given, the learned visual module wherever segmentation is not), and the expert as the
   ceiling (Table 1); the modular agent with the audio module and ground-truth
   segmentation on the study rooms' test episodes with the kitchens' model, and the reverse
   (Table 2), beside Table 1's same agent on the same room kind (its audio module learned on
   both kinds): what changes is only where the audio module learned.
3. ``OUT/table.md`` (both tables, the paper's numbers beside ours, the audio module's scores, the
   episodes used and how long each step took), ``OUT/table.json``, each row's
   ``episodes.jsonl`` / ``summary.json`` under ``OUT/rows/``, the models under ``OUT/models/``
   (the visual module's learning curve beside it), the audio module's scores and confusion
   matrices under ``OUT/audio/`` and the visual module's under ``OUT/vision/``.

A rerun keeps the models and rows already made for the same dataset and selection (the work
resumes); the results depend only on the dataset, the seed and the sizes, not on the workers.
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from fallgen.evaluation.runner import AgentRef
from fallgen.evaluation.scores import (
    PAPER_TABLE1,
    PAPER_TABLE2,
    manifest_hash,
    markdown_table,
    table_rows,
)
from fallgen.evaluation.table_policies import KINDS, OTHER_KIND, POLICY_FACTORY, \
    RANDOM_FACTORY, RANDOM_ORACLE, PolicyRun, budget, policy_lines
from fallgen.evaluation.table_vision import failure_lines, vision_lines

ROWS = "rows"
MODELS = "models"
#: (model name, the train split's room kind it learns from)
AUDIO_MODELS = (("all", None), ("kitchen", "kitchen"), ("study", "study"))
_PAPER1 = {name.strip(): (sr, spl, sna) for name, sr, spl, sna in PAPER_TABLE1}


#: what table.json keeps of the visual module's training (its model file holds the rest)
VISION_TRAINING = ("train_frames", "train_episodes", "frames_seconds", "train_seconds",
                   "device", "settings")
#: the code that decides a row's episodes (the agents, what they see, how they are played and
#: scored; not how the table is written): a row made by other code is run again, not kept
AGENT_CODE = ("agents", "env", "nav", "perception", "learn", "vision", "world",
              "evaluation/runner.py", "evaluation/evaluate.py", "evaluation/scores.py")
#: and, for a trained policy's row, the code that plays it
POLICY_CODE = ("policies",)


@dataclass(frozen=True)
class Row:
    """One line of a table: ``key`` names its directory under ``OUT/rows``; ``model`` the audio
    model it uses (None: none); ``vision`` whether it uses the visual module; ``episodes``
    which selection it runs on; ``factory`` (``module:function``, called with ``kwargs``)
    plays instead of the baseline ``name``, and ``checkpoint_sha256`` is its checkpoint's."""

    key: str
    label: str
    name: str  # baseline
    oracles: tuple[str, ...] = ()
    model: str | None = None
    episodes: str = "test"  # "test", "study" or "kitchen" (the test split's rooms of a kind)
    paper: tuple[float, float, float] | None = None
    note: str = ""
    vision: bool = False
    factory: str = ""
    kwargs: tuple[tuple[str, Any], ...] = ()
    checkpoint_sha256: str | None = None

    def agent(self, models: Mapping[str, str] | None = None) -> AgentRef:
        """The agent that plays the row; ``models``: a baseline's model files by keyword."""
        if self.factory:
            return AgentRef("factory", self.factory, kwargs=dict(self.kwargs))
        return AgentRef("baseline", self.name, oracles=self.oracles, kwargs=dict(models or {}))


def rows_policies(policies: Sequence[PolicyRun] = ()) -> list[Row]:
    """The random walk with the oracle found (PPO's floor), then each trained policy given,
    in the paper's order, labelled with its training's budget."""
    rows = [Row(RANDOM_ORACLE, "Random walk (oracle found)", "", factory=RANDOM_FACTORY,
                kwargs=(("oracle_found", True),))]
    for p in _in_order(p for p in policies if p.room_kind is None):
        rows.append(_policy_row(p, "test", _PAPER1[KINDS[p.kind]]))
    return rows


def _in_order(policies) -> list[PolicyRun]:
    """The paper's order of kinds, then kitchens before study rooms."""
    return sorted(policies, key=lambda p: (list(KINDS).index(p.kind), p.room_kind or ""))


def _policy_row(p: PolicyRun, episodes: str, paper) -> Row:
    """A trained run's row, labelled with its kind, where it learned and its budget:
    'PPO (oracle found, kitchen -> study, 70 k environment steps, 38 min)'."""
    name, extra = KINDS[p.kind], budget(p.training)
    if p.room_kind is not None:
        extra = f"{p.room_kind} -> {OTHER_KIND[p.room_kind]}, {extra}"
    label = f"{name[:-1]}, {extra})" if name.endswith(")") else f"{name} ({extra})"
    return Row(p.key, label, "", paper=paper, episodes=episodes, factory=POLICY_FACTORY,
               kwargs=(("run", str(p.checkpoint)),), checkpoint_sha256=p.sha256)


def rows_table1(policies: Sequence[PolicyRun] = ()) -> list[Row]:
    """Table 1: the random agent, the learned policies given (and the random walk with the
    oracle found), each of the paper's modular rows and Object-Goal with the same kind of
    modules (learned where the paper's were, oracles where its were)."""
    seg, obj, loc = "segmentation", "category", "location"
    return [
        Row("random", "Random", "random"),
        *rows_policies(policies),
        Row("objectgoal", "Object-Goal (vision, 5 candidate categories, no audio)",
            "objectgoal", (), paper=_PAPER1["Object-Goal"], vision=True),
        Row("modular_av", "Modular Planning (audio + vision)", "modular", (), "all",
            paper=_PAPER1["Modular Planning"], vision=True),
        Row("modular_audio_seg", "Modular + audio + GT segmentation", "modular", (seg,), "all",
            paper=_PAPER1["+ GT segmentation"]),
        Row("modular_av_obj", "Modular + audio + vision + GT object", "modular", (obj,), "all",
            paper=_PAPER1["+ GT object"], vision=True),
        Row("modular_audio_seg_obj", "Modular + audio + GT segmentation + object", "modular",
            (seg, obj), "all", paper=_PAPER1["+ GT segmentation + object"]),
        Row("modular_seg_obj_loc", "Modular + GT segmentation + object + location", "modular",
            (seg, obj, loc), paper=_PAPER1["+ GT segmentation + object + location"]),
        Row("expert", "Expert (shortest path)", "expert"),
    ]


def rows_table2(policies: Sequence[PolicyRun] = ()) -> list[Row]:
    """The cross-scene rows: the modular agent with its audio module learned on one room kind,
    tested on the other (its in-domain reference: Table 1's ``modular_audio_seg`` on the same
    room kind, its audio model learned on both kinds); then each trained policy given that
    learned on one room kind alone, on the other kind's test episodes (its reference: the same
    kind's Table 1 run on those rooms)."""
    seg = ("segmentation",)
    k2s, s2k = PAPER_TABLE2["kitchen_to_study"], PAPER_TABLE2["study_to_kitchen"]
    return [
        Row("kitchen_to_study", "kitchen -> study (audio learned on kitchens)", "modular", seg,
            "kitchen", "study", paper=k2s[1:]),
        Row("study_to_kitchen", "study -> kitchen (audio learned on study rooms)", "modular",
            seg, "study", "kitchen", paper=s2k[1:]),
        *(_policy_row(p, OTHER_KIND[p.room_kind], None)
          for p in _in_order(p for p in policies if p.room_kind is not None)),
    ]


@dataclass
class TableRun:
    """What :func:`make_table` made: ``results`` the rows' summaries by key, ``audio`` the
    audio module's scores by the episodes they were scored on, ``vision`` the visual
    module's scores and training, ``timings`` seconds by step."""

    results: dict[str, dict] = field(default_factory=dict)
    audio: dict[str, dict] = field(default_factory=dict)
    vision: dict = field(default_factory=dict)
    vision_meta: dict = field(default_factory=dict)
    timings: dict[str, float] = field(default_factory=dict)
    selection: dict[str, Any] = field(default_factory=dict)
    policies: list[PolicyRun] = field(default_factory=list)


def subsample(ids: Sequence[int], n: int, seed: int, salt: int) -> list[int]:
    """``n`` of ``ids`` drawn without replacement from ``SeedSequence(seed, spawn_key=
    (salt,))`` (all of them, sorted, when ``n`` is 0 or not smaller)."""
    ids = sorted(int(i) for i in ids)
    if n <= 0 or n >= len(ids):
        return ids
    rng = np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(salt,)))
    return sorted(int(i) for i in rng.choice(ids, n, replace=False))


def _of_kind(rows: Sequence[dict], kind: str | None) -> np.ndarray:
    """Which of ``rows`` are of room kind ``kind`` (None: all of them)."""
    return np.array([kind is None or r["room_kind"] == kind for r in rows], bool)


def _read_json(path: Path) -> dict | None:
    try:
        return json.loads(path.read_text())
    except (OSError, json.JSONDecodeError):
        return None


def make_table(dataset: str | Path, out: str | Path, *, episodes: int = 300,
               cross_episodes: int = 200, workers: int = 1, seed: int = 0, trees: int = 300,
               data_dir: str | Path | None = None, vision: bool = True,
               vision_frames: int = 24000, vision_epochs: int = 4, device: str = "cpu",
               vision_model: str | Path | None = None, policies: Sequence[PolicyRun] = (),
               log: Callable[[str], None] = lambda _: None,
               progress: Callable[[str, int, int], None] | None = None) -> TableRun:
    """Train the audio models and the visual module, run every row of both tables and write
    ``OUT`` (see the module's doc). ``episodes`` / ``cross_episodes``: how many test
    episodes Table 1's rows / each room kind of Table 2 run on (0: all); ``vision``: False
    (or no torch) leaves out the rows that need the visual module; ``vision_frames`` and
    ``vision_epochs`` its training (``fallgen vision-model train``'s ``--frames`` and
    ``--epochs``), on ``device``; ``vision_model``: a model file of this dataset to use
    instead of training one; ``policies``: trained runs to score (:class:`PolicyRun`).
    ``progress(step, done, total)``."""
    from fallgen.atomic import write_text
    from fallgen.dataset.integrity import code_digest
    from fallgen.dataset.manifest import sha256 as file_sha256
    from fallgen.dataset.reader import Dataset
    from fallgen.evaluation.evaluate import evaluate, write
    from fallgen.evaluation.table_vision import vision_module
    from fallgen.perception.audio_model import (
        AudioModel,
        check_features,
        confusion_png,
        dataset_features,
        feature_matrix,
    )
    from fallgen.perception.audio_model import evaluate as score_audio
    from fallgen.world.library import load_world

    t_start = time.perf_counter()
    out = Path(out)
    ds = Dataset(dataset)
    for split in ("train", "test"):
        if split not in ds.splits:
            raise ValueError(f"split={split!r}: {ds.root} has {', '.join(ds.splits)}")
    sha = manifest_hash(ds.root) or ""
    run = TableRun()
    test_rows = ds.rows("test")
    by_kind = {k: [r["episode_id"] for r in test_rows if r["room_kind"] == k]
               for k in ("kitchen", "study")}
    chosen = {"test": subsample([r["episode_id"] for r in test_rows], episodes, seed, 1),
              "kitchen": subsample(by_kind["kitchen"], cross_episodes, seed, 2),
              "study": subsample(by_kind["study"], cross_episodes, seed, 3)}
    run.selection = {"dataset": str(ds.root), "manifest_sha256": sha, "seed": seed,
                     "trees": trees, "test_split": len(test_rows),
                     "table1": len(chosen["test"]), "kitchen": len(chosen["kitchen"]),
                     "study": len(chosen["study"])}

    # -- the audio models ----------------------------------------------------------------
    t0 = time.perf_counter()
    world = load_world(data_dir)
    train_rows = ds.rows("train")
    features = dataset_features(ds, train_rows)
    X_train: np.ndarray | None = None
    models: dict[str, Path | None] = {}
    loaded: dict[str, AudioModel] = {}  # each model once, made or read
    for name, kind in AUDIO_MODELS:
        path = out / MODELS / f"audio-{name}.model"
        keep = _of_kind(train_rows, kind)
        if keep.sum() < 2:
            models[name] = None
            log(f"audio model {name}: {keep.sum()} train episode(s) of {kind} rooms: none made")
            continue
        models[name] = path
        if path.is_file():
            try:
                m = AudioModel.load(path)
                if m.manifest_sha256 == sha and m.meta.get("trees") == trees \
                        and m.meta.get("seed") == seed:
                    loaded[name] = m
                    log(f"audio model {name}: kept {path}")
                    continue
            except Exception:  # noqa: BLE001 - a stale or broken file is made again
                pass
        if X_train is None:
            X_train = feature_matrix(ds, train_rows, features, _step(progress, "features",
                                                                     len(train_rows)))
        rows_k = [r for r, k in zip(train_rows, keep) if k]
        m = AudioModel.train(ds, rows_k, seed=seed, trees=trees, X=X_train[keep], world=world)
        m.meta.update({"split": "train", "room_kind": kind, "dataset": str(ds.root)})
        m.save(path)
        loaded[name] = m
        log(f"audio model {name}: {len(rows_k)} train episodes -> {path}")
    run.timings["audio models"] = time.perf_counter() - t0

    # -- the audio module's scores on the episodes each model is used on ------------------
    t0 = time.perf_counter()
    scored = (("all", "test", None), ("all", "kitchen", "kitchen"), ("all", "study", "study"),
              ("kitchen", "study", "study"), ("study", "kitchen", "kitchen"))
    for name, m in loaded.items():
        check_features(ds, test_rows, m.features, models[name], m.hrtf)
    X_test = None
    for name, where, kind in scored:
        key = f"{name}_on_{where}"
        keep = _of_kind(test_rows, kind)
        rows_k = [r for r, k in zip(test_rows, keep) if k]
        if name not in loaded or not rows_k:
            continue
        m = loaded[name]
        if X_test is None:
            X_test = feature_matrix(ds, test_rows, m.features,
                                    _step(progress, "test features", len(test_rows)))
        prior_rows = [r for r in train_rows if m.meta.get("room_kind") in (None, r["room_kind"])]
        scores, confusion = score_audio(m, ds, rows_k, prior_rows, world, X=X_test[keep])
        run.audio[key] = scores
        if key == "all_on_test":
            (out / "audio").mkdir(parents=True, exist_ok=True)
            write_text(out / "audio" / "scores.json", json.dumps(scores, indent=1) + "\n")
            for cname, (matrix, labels) in confusion.items():
                confusion_png(matrix, labels, cname, out / "audio" / f"confusion_{cname}.png")
    run.timings["audio scores"] = time.perf_counter() - t0

    # -- the visual module ---------------------------------------------------------------------
    vision_path = None
    if vision:
        part = vision_module(ds, out, out / MODELS, sha, chosen["test"], seed, vision_frames,
                             vision_epochs, device, workers, data_dir, log, progress,
                             None if vision_model is None else Path(vision_model))
        if part is not None:
            vision_path, run.vision, run.vision_meta = part.path, part.scores, part.meta
            run.timings.update(part.timings)

    # -- the agents ----------------------------------------------------------------------------
    base_code = "+".join(code_digest(g) for g in AGENT_CODE)
    policy_code = base_code + "+" + "+".join(code_digest(g) for g in POLICY_CODE)
    run.policies = list(policies)
    for row in rows_table1(policies) + rows_table2(policies):
        code = policy_code if row.factory == POLICY_FACTORY else base_code
        ids = chosen[row.episodes]
        if not ids or (row.model and models[row.model] is None) or \
                (row.vision and vision_path is None):
            log(f"{row.key}: not run (no {row.episodes} test episode or no model)")
            continue
        kwargs = {"audio_model": str(models[row.model])} if row.model else {}
        model_sha = file_sha256(models[row.model]) if row.model else None
        vision_sha = None
        if row.vision:
            kwargs["vision_model"] = str(vision_path)
            vision_sha = file_sha256(vision_path)
        ref = row.agent(kwargs)
        row_dir = out / ROWS / row.key
        old = _read_json(row_dir / "summary.json")
        if old is not None and old.get("manifest_sha256") == sha and \
                old.get("code_digest") == code and \
                old.get("agent") == ref.describe() and old.get("seed") == seed and \
                old.get("episode_ids") == ids and old.get("audio_model_sha256") == model_sha \
                and old.get("vision_model_sha256") == vision_sha and \
                old.get("checkpoint_sha256") == row.checkpoint_sha256:
            run.results[row.key] = old
            run.timings[row.key] = float(old.get("wall_s", 0.0))
            log(f"{row.key}: kept ({old['n']} episodes)")
            continue
        t0 = time.perf_counter()
        ev = evaluate(ds.root, ref, split=None, episode_ids=ids, workers=workers, seed=seed,
                      data_dir=data_dir, progress=_step(progress, row.key, len(ids)))
        wall = time.perf_counter() - t0
        ev.summary.update({"episode_ids": ids, "wall_s": round(wall, 1), "code_digest": code,
                           "audio_model_sha256": model_sha, "vision_model_sha256": vision_sha,
                           "checkpoint_sha256": row.checkpoint_sha256})
        write(ev, row_dir)
        run.results[row.key] = ev.summary
        run.timings[row.key] = wall
        log(f"{row.key}: SR {ev.summary['success']:.3f} on {len(ids)} episodes, {wall:.0f} s")
    run.timings["total"] = time.perf_counter() - t_start
    write_text(out / "table.json", json.dumps(
        {"selection": run.selection, "results": {k: _brief(v) for k, v in run.results.items()},
         "audio": run.audio, "vision": run.vision,
         "vision_training": {k: run.vision_meta[k] for k in VISION_TRAINING
                             if k in run.vision_meta},
         "policy_training": {p.key: {"checkpoint": str(p.checkpoint), "sha256": p.sha256,
                                     **p.training} for p in run.policies},
         "timings_s": {k: round(v, 1) for k, v in run.timings.items()}},
        indent=1, sort_keys=True) + "\n")
    write_text(out / "table.md", markdown(run))
    return run


def _step(progress, name: str, total: int):
    if progress is None:
        return None
    done = [0]

    def tick(n: int) -> None:
        done[0] += n
        progress(name, done[0], total)

    tick(0)
    return tick


def _brief(summary: dict) -> dict:
    keys = ("success", "spl", "sna", "soft_spl", "n", "ci95", "outcomes", "mean_steps",
            "seen_share", "agent", "by_room_kind", "by_zone_kind", "wall_s")
    return {k: summary[k] for k in keys if k in summary}


def _paper(p: tuple[float, float, float] | None) -> str:
    return " / ".join(f"{v:.2f}" for v in p) if p else "-"


def _used(what: str, n: int, of: int, unit: str) -> str:
    if n >= of:
        return f"{what}: all {of} {unit}."
    return f"{what}: a seeded subsample of {n} of the {of} {unit} (`--episodes`)."


def _minutes(s: float) -> str:
    return f"{s / 60:.1f} min"


def _result(run: TableRun, row: Row) -> tuple[str, ...]:
    """A row's cells: method, SR / SPL / SNA with their intervals, the paper's, episodes,
    time."""
    s = run.results[row.key]
    return (*table_rows(s, row.label)[0], _paper(row.paper), str(s["n"]),
            _minutes(run.timings.get(row.key, 0.0)))


def markdown(run: TableRun) -> str:
    """``table.md``: both tables, the audio module's scores and the timings."""
    sel = run.selection
    lines = [f"# Table 1 and Table 2 on `{sel['dataset']}`", "",
             f"Manifest sha256 `{sel['manifest_sha256'][:16]}...`; seed {sel['seed']}; "
             f"audio models of {sel['trees']} trees per target. "
             + _used("Table 1", sel["table1"], sel["test_split"], "test episodes") + " "
             + f"Table 2: {sel['kitchen']} kitchen and {sel['study']} study-room test "
             "episodes (seeded; `--cross-episodes`).", ""]
    lines += ["## Table 1 (test split)", "", markdown_table(
        [_result(run, row) for row in rows_table1(run.policies) if row.key in run.results],
        ("Method", "SR [95 % CI]", "SPL", "SNA", "paper SR / SPL / SNA", "episodes", "time")
    ).rstrip("\n")]
    lines += ["", "Each row has the paper's kind of modules: the learned audio module wherever "
              "the category or the place is not given (the agent heads for the heard place "
              "and looks for the heard category), the learned visual module (`fallgen "
              "vision-model`: a small encoder-decoder segmenting the 31 target categories "
              "from RGB-D; the paper's was a Mask R-CNN) wherever segmentation is not. "
              "Object-Goal has the visual module and no audio: told five candidate "
              "categories (the true one and four drawn per episode), it explores frontiers "
              "and claims the candidate-category object it has seen best.", ""]
    lines += policy_lines(run.policies, run.results)
    lines += vision_lines(run.vision, run.vision_meta)
    lines += failure_lines(run.results, {r.key: r.label for r in rows_table1(run.policies)})
    lines += ["", "## Table 2 (cross-scene: learned on one room kind, tested on the other)", "",
              "The modular agent (audio module + GT segmentation) with its audio module "
              "learned on one room kind, and the trained policies given that learned on one "
              "room kind alone (`fallgen train --room-kind`). Under each row, the same agent "
              "learned on both kinds: its Table 1 row on that row's room kind.", ""]
    table2 = []
    for row in rows_table2(run.policies):
        if row.key not in run.results:
            continue
        table2.append(_result(run, row))
        refs = [("modular_audio_seg", "audio learned on both kinds")]
        if row.factory == POLICY_FACTORY:
            kind = next(p.kind for p in run.policies if p.key == row.key)
            refs = [(kind, "trained on both kinds")] + \
                ([(RANDOM_ORACLE, "the random walk with the oracle found")]
                 if kind == "ppo" else [])
        for key, what in refs:
            ref = run.results.get(key, {}).get("by_room_kind", {}).get(row.episodes)
            if ref:
                table2.append((f"{row.episodes} rooms, {what} (Table 1's row, its "
                               f"{row.episodes} episodes)", *(f"{ref[m]:.2f}" for m in
                                                             ("success", "spl", "sna")),
                               "-", str(ref["n"]), "-"))
    lines.append(markdown_table(table2, ("Test rooms, agent", "SR [95 % CI]", "SPL", "SNA",
                                         "paper SR / SPL / SNA", "episodes", "time")
                                ).rstrip("\n"))
    lines += ["", "## The audio module on the test episodes", "",
              "| model on episodes | category top-1 / top-5 | material | azimuth err (deg) | "
              "lateral err (deg) | distance rank corr. (within a room) | told the room: rank "
              "corr. (within a room) | position err (m) | "
              "prior: top-1 / top-5, material, azimuth, lateral, rank corr. (within a room) |",
              "|---|---|---|---|---|---|---|---|---|"]
    for key, a in run.audio.items():
        p = a["prior"]
        lines.append(
            f"| {key.replace('_on_', ' on ')} ({a['episodes']}) | {a['category_top1']:.3f} / "
            f"{a['category_top5']:.3f} | {a['material_top1']:.3f} | "
            f"{a['azimuth_median_error_deg']:.1f} | {a['lateral_median_error_deg']:.1f} | "
            f"{a['distance_rank_correlation']:.3f} "
            f"({a.get('distance_rank_correlation_within_room', float('nan')):.3f}) | "
            f"{a.get('distance_rank_correlation_told_room', float('nan')):.3f} "
            f"({a.get('distance_rank_correlation_within_room_told_room', float('nan')):.3f}) | "
            f"{a['position_median_error_m']:.2f} | "
            f"{p['category_top1']:.3f} / {p['category_top5']:.3f}, {p['material_top1']:.3f}, "
            f"{p['azimuth_median_error_deg']:.1f}, {p['lateral_median_error_deg']:.1f}, "
            f"{p['distance_rank_correlation']:.3f} "
            f"({p.get('distance_rank_correlation_within_room', float('nan')):.3f}) |")
    lines += ["", "Prior: what a planner knows without listening (the train split's most "
              "frequent categories and material; the room's centre as where the fall was).", "",
              "## Time", "", "| step | time |", "|---|---|"]
    lines += [f"| {k} | {_minutes(v)} |" for k, v in run.timings.items()]
    return "\n".join(lines) + "\n"


__all__ = ["Row", "TableRun", "make_table", "markdown", "rows_table1", "rows_table2",
           "rows_policies", "subsample"]
