"""``fallgen evaluate``: score an agent on a dataset's episodes and write the results.

``OUT/episodes.jsonl``: one line per episode, sorted by id (the row's split, room, zone kind,
category, then success, spl, sna, soft_spl, path length, shortest path, fewest actions,
distance to the object, first-seen step, claims, outcome, steps, return and the actions);
``OUT/summary.json``: :func:`fallgen.evaluation.scores.summarize`. Both are written once every
episode is done (nothing half-written), with sorted keys and no timings: the same agent on the
same episodes writes the same bytes, whatever the worker count.
"""

from __future__ import annotations

import json
from collections.abc import Callable, Collection, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from fallgen.evaluation.runner import AgentRef, run_episodes
from fallgen.evaluation.scores import manifest_hash, summarize

EPISODES = "episodes.jsonl"
SUMMARY = "summary.json"


@dataclass(frozen=True)
class Evaluation:
    records: list[dict[str, Any]]
    summary: dict[str, Any]


def load_actions(path: str | Path) -> dict[int, tuple[int, ...]]:
    """Action sequences by episode id from ``path``: a JSON object ``{"17": [0, 1, 5], ...}``,
    a JSON list of ``{"episode_id": 17, "actions": [...]}``, or JSON lines of such objects
    (``episodes.jsonl`` of an earlier evaluation). ValueError naming the file and what is
    wrong."""
    path = Path(path)
    try:
        text = path.read_text()
    except OSError as e:
        raise ValueError(f"{path}: cannot read: {e.strerror}") from None
    try:
        data: Any = json.loads(text)
    except json.JSONDecodeError:
        try:
            data = [json.loads(line) for line in text.splitlines() if line.strip()]
        except json.JSONDecodeError as e:
            raise ValueError(f"{path}: line {e.lineno}: not JSON") from None
    if isinstance(data, dict):
        items = list(data.items())
    elif isinstance(data, list):
        try:
            items = [(d["episode_id"], d["actions"]) for d in data]
        except (TypeError, KeyError):
            raise ValueError(f"{path}: each entry needs episode_id and actions") from None
    else:
        raise ValueError(f"{path}: expected an object or a list of episodes")
    out: dict[int, tuple[int, ...]] = {}
    for k, acts in items:
        try:
            eid = int(k)
            seq = tuple(int(a) for a in acts)
        except (TypeError, ValueError):
            raise ValueError(f"{path}: episode {k!r}: actions must be a list of integers") \
                from None
        if any(not 0 <= a <= 5 for a in seq):
            raise ValueError(f"{path}: episode {eid}: actions must be 0..5")
        if eid in out:
            raise ValueError(f"{path}: episode {eid} appears twice")
        out[eid] = seq
    return out


def evaluate(dataset: str | Path, agent: AgentRef, *, split: str | None = "test",
             room_kind: str | None = None, cross_scene: str | None = None,
             categories: Collection[str] | None = None,
             episode_ids: Sequence[int] | None = None, workers: int = 1, claims: int = 1,
             reward: str = "paper", seed: int = 0, data_dir: str | Path | None = None,
             progress: Callable[[int], None] | None = None,
             on_selected: Callable[[int], None] | None = None) -> Evaluation:
    """Run ``agent`` on the selected episodes (``cross_scene``: ``kitchen_to_study`` tests
    on the study rooms, ``study_to_kitchen`` on the kitchens, of ``split``) and score them.
    With ``agent.kind == "actions"`` every selected episode must have a sequence.
    ``on_selected`` gets the number of episodes before they run."""
    import fallgen
    from fallgen.dataset.reader import Dataset
    from fallgen.env.source import CROSS_SCENE, select

    ds = Dataset(dataset)
    if cross_scene is not None:
        if cross_scene not in CROSS_SCENE:
            raise ValueError(f"cross_scene={cross_scene!r}: one of {', '.join(CROSS_SCENE)}")
        test_kind = CROSS_SCENE[cross_scene][1]
        if room_kind is not None and room_kind != test_kind:
            raise ValueError(f"cross_scene {cross_scene} tests on {test_kind} rooms, not "
                             f"{room_kind}")
        room_kind = test_kind
    if agent.kind == "actions" and episode_ids is None:
        # the episodes of the file that the split and room kind select
        chosen = set(select(ds, split, room_kind, categories))
        missing = sorted(chosen - set(agent.actions or {}))
        if missing:
            raise ValueError(f"no actions for episode {missing[0]} ({len(missing)} of the "
                             f"{len(chosen)} selected episodes have none)")
    ids = select(ds, split, room_kind, categories, episode_ids)
    if agent.kind == "actions":
        missing = [i for i in ids if i not in (agent.actions or {})]
        if missing:
            raise ValueError(f"no actions for episode {missing[0]}")
    if on_selected:
        on_selected(len(ids))
    records = run_episodes(ds.root, ids, agent, workers=workers, claims=claims, reward=reward,
                           seed=seed, data_dir=data_dir, progress=progress)
    meta = {"dataset": str(ds.root), "manifest_sha256": manifest_hash(ds.root),
            "fallgen_version": fallgen.__version__, "agent": agent.describe(),
            "selection": {"split": split, "room_kind": room_kind, "cross_scene": cross_scene,
                          "categories": sorted(categories) if categories else None,
                          "episodes": len(ids)},
            "claims": claims, "reward": reward, "seed": seed}
    return Evaluation(records, summarize(records, meta))


def write(ev: Evaluation, out: str | Path) -> tuple[Path, Path]:
    """Write ``episodes.jsonl`` and ``summary.json`` into ``out`` (atomically each)."""
    from fallgen.atomic import write_text

    out = Path(out)
    lines = "".join(json.dumps(r, sort_keys=True) + "\n" for r in ev.records)
    a = write_text(out / EPISODES, lines)
    b = write_text(out / SUMMARY, json.dumps(ev.summary, indent=1, sort_keys=True) + "\n")
    return a, b


__all__ = ["Evaluation", "evaluate", "write", "load_actions", "EPISODES", "SUMMARY"]
