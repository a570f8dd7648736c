"""The learned policies' part of ``fallgen table`` (:mod:`fallgen.evaluation.table`): the
trained runs it scores beside the paper's Decision Transformer, PPO (oracle found) and SAVi
rows, the floor the oracle found sets, and their section of ``table.md``.

The table does not train policies (hours each: ``fallgen train``); it scores the runs it is
given (``fallgen table --policy KIND=RUN``) on Table 1's test episodes, each row labelled with
what its training spent. A run is described by a :class:`PolicyRun`, made by the caller (the
CLI reads the checkpoint and refuses one of another dataset), so this package does not import
the policies'. PPO ends its episodes with the oracle found (the paper's rule: within 2 m and in
view), which a random walk is also given in the row :data:`RANDOM_ORACLE` (the five moves drawn
uniformly): that, not the plain random agent, is the floor PPO's row is compared with.
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


def budget(training: Mapping[str, Any]) -> str:
    """What a run's training spent, in a few words: '140 k environment steps, 180 min'."""
    steps, unit = int(training.get("steps", 0)), str(training.get("unit", "steps"))
    n = f"{steps / 1000:.0f} k" if steps >= 10_000 else f"{steps}"
    return f"{n} {unit}, {float(training.get('wall_s', 0.0)) / 60:.0f} min"


def parse_policies(specs: Sequence[str]) -> dict[str, str]:
    """``KIND=RUN`` strings -> kind -> run; ValueError naming a malformed or repeated one."""
    out: dict[str, str] = {}
    for spec in specs:
        kind, sep, run = spec.partition("=")
        kind = kind.strip()
        if not sep or not run.strip():
            raise ValueError(f"{spec!r}: KIND=RUN, e.g. ppo=runs/ppo")
        if kind not in KINDS:
            raise ValueError(f"{spec!r}: KIND is one of {', '.join(KINDS)}")
        if kind in out:
            raise ValueError(f"{spec!r}: {kind} given twice")
        out[kind] = run.strip()
    return out


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
        s = results.get(r.kind)
        if s is None:
            continue
        t = r.training
        out.append(f"{KINDS[r.kind]}: {budget(t)}, "
                   f"{int(t.get('updates', 0))} updates, checkpoint `{r.checkpoint.name}` "
                   f"(sha256 {r.sha256[:12]}); SR {s['success']:.3f}.")
    floor = results.get(RANDOM_ORACLE)
    if floor is not None:
        out.append(f"A random walk given PPO's oracle found (the five moves drawn uniformly; "
                   f"the episode ends in success once the object is within 2 m and in view) "
                   f"succeeds in {floor['success']:.2f} of the episodes: the floor for PPO's "
                   f"row, far above the plain random agent's, since the oracle claims for it.")
    return [" ".join(out), ""]


__all__ = ["KINDS", "POLICY_FACTORY", "RANDOM_FACTORY", "RANDOM_ORACLE", "PolicyRun",
           "budget", "parse_policies", "policy_lines"]
