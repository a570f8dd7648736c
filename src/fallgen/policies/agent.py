"""A trained run as a ``fallgen evaluate`` agent: ``fallgen evaluate DATASET --agent RUN``, or
``--agent fallgen.policies.agent:load_run --agent-kwargs '{"run": "RUN"}'``.

:func:`load_run` reads the run's last checkpoint (or the checkpoint file given) and makes the
agent of its kind: :class:`fallgen.policies.ppo.PpoAgent`,
:class:`fallgen.policies.dt.DtAgent`, :class:`fallgen.policies.savi.SaviAgent`. Each takes
the environment's own observations (it declares the sensors it needs) and makes them what it
was trained on.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any


def load_run(run: str | Path, checkpoint: str | Path | None = None,
             deterministic: bool = False, device: str = "cpu") -> Any:
    """The agent of run directory ``run`` (its last checkpoint) or of ``checkpoint``."""
    from fallgen.policies.runs import find_checkpoint, load_checkpoint
    from fallgen.learn.runtime import resolve_device

    dev = resolve_device(device)
    path = Path(checkpoint) if checkpoint is not None else find_checkpoint(run)
    ck = load_checkpoint(path, device=dev)
    kind = ck.get("kind")
    if kind == "ppo":
        from fallgen.policies.ppo import PpoAgent

        return PpoAgent(ck, deterministic=deterministic, device=dev)
    if kind == "dt":
        from fallgen.policies.dt import DtAgent

        return DtAgent(ck, deterministic=deterministic, device=dev)
    if kind == "savi":
        from fallgen.policies.savi import SaviAgent

        return SaviAgent(ck, deterministic=deterministic, device=dev, path=path)
    from fallgen.errors import InputError

    raise InputError(path, "kind", f"{kind!r}: not a policy fallgen trains")


def is_run(path: str | Path) -> bool:
    """Whether ``path`` is a run directory (its run.json) or a checkpoint file."""
    p = Path(path)
    return (p.is_dir() and (p / "run.json").is_file()) or (p.is_file() and p.suffix == ".pt")


__all__ = ["load_run", "is_run"]
