"""The learned policies' part of ``fallgen table`` (:mod:`fallgen.evaluation.table`): the
trained runs it scores beside the paper's Decision Transformer, PPO (oracle found) and SAVi
rows, the floor the oracle found sets, and their section of ``table.md``.

The table does not train policies (hours each: ``fallgen train``); it scores the runs it is
given (``fallgen table --policy KIND=RUN``), each row labelled with what its training spent: a
run trained on every room kind on Table 1's test episodes, a run trained on one room kind
(``fallgen train --room-kind``) in Table 2, on the other kind's test episodes. A run is
described by a :class:`PolicyRun`, made by the caller (the CLI reads the checkpoint and refuses
one of another dataset), so this package does not import the policies'. PPO ends its
episodes with the oracle found (the paper's rule: within 2 m and in view), which a random walk
is also given in the row :data:`RANDOM_ORACLE` (the five moves drawn uniformly): that, not the
plain random agent, is the floor PPO's row is compared with.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

#: the kinds of trained policy, in the paper's order, and their rows' names there
KINDS = {"dt": "Decision Transformer", "ppo": "PPO (oracle found)", "savi": "SAVi"}
#: what a factory row plays: a trained run (its checkpoint file) or the random walk
POLICY_FACTORY = "fallgen.policies.agent:load_run"
RANDOM_FACTORY = "fallgen.agents.random_agent:RandomAgent"
#: the key of the random walk with the oracle found
RANDOM_ORACLE = "random_oracle_found"
#: the room kind a cross-scene run is tested on, by the kind it was trained on
OTHER_KIND = {"kitchen": "study", "study": "kitchen"}


@dataclass(frozen=True)
class PolicyRun:
    """A trained policy to score: its ``kind`` (a key of :data:`KINDS`), its checkpoint file,
    that file's sha256 (a row of another checkpoint is run again) and what its training spent
    (``training``: ``steps``, ``unit`` — environment steps or gradient steps —, ``updates``,
    ``wall_s``, ``settings``)."""

    kind: str
    checkpoint: Path
    sha256: str
    training: Mapping[str, Any] = field(default_factory=dict)

    @property
    def room_kind(self) -> str | None:
        """The room kind it was trained on alone (``fallgen train --room-kind``), or None."""
        return (self.training.get("settings") or {}).get("room_kind")

    @property
    def key(self) -> str:
        """Its row's key: the kind (Table 1), or e.g. ``ppo_kitchen_to_study`` (Table 2)."""
        rk = self.room_kind
        return self.kind if rk is None else f"{self.kind}_{rk}_to_{OTHER_KIND[rk]}"


def budget(training: Mapping[str, Any]) -> str:
    """What a run's training spent, in a few words: '140 k environment steps, 180 min'."""
    steps, unit = int(training.get("steps", 0)), str(training.get("unit", "steps"))
    n = f"{steps / 1000:.0f} k" if steps >= 10_000 else f"{steps}"
    return f"{n} {unit}, {float(training.get('wall_s', 0.0)) / 60:.0f} min"


def parse_policies(specs: Sequence[str]) -> list[tuple[str, str]]:
    """``KIND=RUN`` strings -> (kind, run) pairs; ValueError naming a malformed or repeated
    one (a kind may come more than once: trained on every room kind and on one alone, which
    :func:`check_distinct` checks once the runs are read)."""
    out: list[tuple[str, str]] = []
    for spec in specs:
        kind, sep, run = spec.partition("=")
        kind, run = kind.strip(), run.strip()
        if not sep or not run:
            raise ValueError(f"{spec!r}: KIND=RUN, e.g. ppo=runs/ppo")
        if kind not in KINDS:
            raise ValueError(f"{spec!r}: KIND is one of {', '.join(KINDS)}")
        if (kind, run) in out:
            raise ValueError(f"{spec!r}: given twice")
        out.append((kind, run))
    return out


def check_distinct(runs: Sequence[PolicyRun]) -> None:
    """ValueError when two runs would make the same row: the same kind trained on the same
    rooms."""
    seen: dict[str, PolicyRun] = {}
    for r in runs:
        if r.room_kind is not None and r.room_kind not in OTHER_KIND:
            raise ValueError(f"{r.checkpoint}: trained on room kind {r.room_kind!r} "
                             f"(one of {', '.join(OTHER_KIND)})")
        if r.key in seen:
            rooms = f"{r.room_kind} rooms" if r.room_kind else "every room kind"
            raise ValueError(f"{seen[r.key].checkpoint} and {r.checkpoint}: two {r.kind} runs "
                             f"trained on {rooms}")
        seen[r.key] = r


def policy_lines(runs: Sequence[PolicyRun], results: Mapping[str, dict]) -> list[str]:
    """table.md's paragraph on the learned policies' rows: how each was trained, and PPO
    against the random walk with the same oracle."""
    if not runs and RANDOM_ORACLE not in results:
        return []
    out = ["The learned policies (`fallgen train KIND`, scored with `fallgen evaluate --agent "
           "RUN`) read RGB, depth, the oracle segmentation and the step-0 clip through one "
           "encoder (docs/policies.md); each row names what its training spent, far below "
           "the paper's (10^7 environment steps on GPUs)."]
    for r in runs:
        s = results.get(r.key)
        if s is None:
            continue
        t = r.training
        where = "" if r.room_kind is None else (f", trained on {r.room_kind} rooms alone and "
                                                 f"tested on {OTHER_KIND[r.room_kind]} rooms")
        out.append(f"{KINDS[r.kind]}{where}: {budget(t)}, "
                   f"{int(t.get('updates', 0))} updates, checkpoint `{r.checkpoint.name}` "
                   f"(sha256 {r.sha256[:12]}); SR {s['success']:.3f}.")
    floor = results.get(RANDOM_ORACLE)
    if floor is not None:
        out.append(f"A random walk given PPO's oracle found (the five moves drawn uniformly; "
                   f"the episode ends in success once the object is within 2 m and in view) "
                   f"succeeds in {floor['success']:.2f} of the episodes: the floor for PPO's "
                   f"row, far above the plain random agent's, since the oracle claims for it.")
    return [" ".join(out), ""]


__all__ = ["KINDS", "OTHER_KIND", "POLICY_FACTORY", "RANDOM_FACTORY", "RANDOM_ORACLE",
           "PolicyRun", "budget", "check_distinct", "parse_policies", "policy_lines"]
