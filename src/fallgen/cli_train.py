"""``fallgen train {ppo,dt,savi} DATASET -o RUN``: the paper's learned policies
(:mod:`fallgen.policies`), trained in pieces; registered on the main app by :mod:`fallgen.cli`.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Optional

import typer

from fallgen.errors import InputError

if TYPE_CHECKING:
    from fallgen.evaluation.table_policies import PolicyRun

#: Settings a resumed run may be given anew (the budget, how often it checkpoints, how many
#: environment workers); any other differing from the run's is refused.
MUTABLE = ("timesteps", "steps", "checkpoint_every", "envs", "eval_every", "eval_episodes")


def parse_sets(items: list[str] | None) -> dict[str, str]:
    """``["k=v", ...]`` -> {k: v}; a malformed item is a one-line error."""
    out: dict[str, str] = {}
    for item in items or []:
        k, sep, v = item.partition("=")
        if not sep or not k.strip():
            raise InputError("<command line>", "--set", f"{item!r}: expected NAME=VALUE")
        out[k.strip()] = v.strip()
    return out


def _module(kind: str):
    import importlib

    return importlib.import_module(f"fallgen.policies.{kind}")


def register(app: typer.Typer, console) -> None:
    @app.command("train")
    def train(
        kind: Annotated[str, typer.Argument(help="ppo (oracle found), dt (Decision "
                                            "Transformer) or savi.", metavar="KIND")],
        dataset: Annotated[Path, typer.Argument(help="A dataset directory.",
                                                metavar="DATASET")],
        out: Annotated[Path, typer.Option("--out", "-o", help="The run directory (resumed "
                                          "from its last checkpoint when it has one).")],
        device: Annotated[str, typer.Option(help="cpu or cuda.")] = "cpu",
        seed: Annotated[int, typer.Option(help="Seeds the weights, the episodes' order "
                                          "and the sampling.")] = 0,
        minutes: Annotated[Optional[float], typer.Option(
            help="Stop after this long with a checkpoint (run again to go on; default: the "
                 "kind's budget: dt 60, ppo and savi 180).", show_default=False)] = None,
        envs: Annotated[Optional[int], typer.Option(
            min=0, help="Environment worker processes (ppo, savi; 0: one in this process; "
                        "default 2).", show_default=False)] = None,
        budget: Annotated[Optional[int], typer.Option(
            min=1, help="The run's total budget: environment steps (ppo, savi) or gradient "
                        "steps (dt).", show_default=False)] = None,
        room_kind: Annotated[Optional[str], typer.Option(
            help="Train on this room kind only (kitchen or study: Table 2's cross-scene "
                 "runs).", show_default=False)] = None,
        expert: Annotated[Optional[Path], typer.Option(
            help="dt: the expert trajectories (fallgen export-expert --sensors "
                 "rgb,depth,audio,pose,category_seg; default: exported into RUN/expert).",
            show_default=False)] = None,
        threads: Annotated[int, typer.Option(min=1, help="torch's threads.")] = 1,
        set_: Annotated[Optional[list[str]], typer.Option(
            "--set", help="A setting NAME=VALUE (repeatable; the names are in the kind's "
                          "module docstring and run.json).", show_default=False)] = None,
    ) -> None:
        """Train the paper's learned policies: PPO with the oracle found, the Decision
        Transformer on the expert's trajectories, SAVi. Checkpoints, RUN/log.csv and
        RUN/curve.png; score with fallgen evaluate DATASET --agent RUN."""
        from fallgen.policies import KINDS
        from fallgen.policies.runs import Run, dataset_hash

        if kind not in KINDS:
            raise InputError("<command line>", "KIND", f"{kind!r}: one of {', '.join(KINDS)}")
        if room_kind is not None and room_kind not in ("kitchen", "study"):
            raise InputError("<command line>", "--room-kind", f"{room_kind!r}: kitchen or "
                             "study")
        if expert is not None and kind != "dt":
            raise InputError("<command line>", "--expert", "only for dt")
        if envs is not None and kind == "dt":
            raise InputError("<command line>", "--envs", "only for ppo and savi")
        given = parse_sets(set_)
        if envs is not None:
            given["envs"] = str(envs)
        if budget is not None:
            given["steps" if kind == "dt" else "timesteps"] = str(budget)
        if room_kind is not None:
            given["room_kind"] = room_kind
        try:
            from fallgen.learn.runtime import resolve_device

            resolve_device(device)
            mod = _module(kind)
        except ImportError as e:
            raise InputError("<command line>", "KIND", str(e)) from None
        except ValueError as e:
            raise InputError("<command line>", "--device", str(e)) from None
        try:
            cfg = mod.settings(given)
        except ValueError as e:
            raise InputError("<command line>", "--set", str(e)) from None
        from fallgen.cli_common import open_dataset

        ds = open_dataset(dataset)
        digest = dataset_hash(dataset)
        rows = ds.rows()
        if not rows:
            raise InputError(dataset, "data/", "no episodes")
        config = cfg.to_dict() | {"sample_rate": int(rows[0]["sample_rate"])}
        typed = {k: config[k] for k in given}
        if expert is not None:  # before the run is made: a bad file leaves nothing behind
            from fallgen.policies.dt_data import expert_file

            expert_file(dataset, digest, out, expert)
        run = Run(out)
        fixed = {k: v for k, v in typed.items() if k not in MUTABLE}
        config = run.start(kind, dataset, digest, config, fixed)
        config.update({k: v for k, v in typed.items() if k in MUTABLE})
        if kind != "dt":  # each worker plays its own slice of the split's episodes
            try:
                n_eps = len(ds.ids(config["split"], config.get("room_kind")))
            except (KeyError, ValueError) as e:
                raise InputError(dataset, "split", str(e)) from None
            if int(config["envs"]) > n_eps:
                raise InputError("<command line>", "--envs", f"{config['envs']} workers for "
                                 f"{n_eps} episodes of {dataset}'s {config['split']} split "
                                 "(at most one worker an episode)")
        extra = {"expert": expert} if kind == "dt" else {}
        limit = minutes if minutes is not None else mod.DEFAULT_MINUTES
        from fallgen.cli_common import step_bars

        with step_bars(console) as progress:
            try:
                res = mod.train(dataset, run, config, digest, seed=seed, device=device,
                                minutes=limit, threads=threads, progress=progress, **extra)
            except ValueError as e:
                raise InputError("<command line>", "DATASET", str(e)) from None
        h, m = divmod(int(res["wall_s"]) // 60, 60)
        what = "timesteps" if kind != "dt" else "gradient steps"
        state = "budget spent" if res["done"] else \
            f"stopped after {limit:g} min: run the same command again to go on"
        console.print(f"{kind}: update {res['updates']}, {res.get('timesteps', 0)} {what}, "
                      f"{h}:{m:02d} h in all ({state}); checkpoint {res['checkpoint']}; "
                      f"log {run.log_path}; curve {run.curve_path}", markup=False,
                      highlight=False, soft_wrap=True)


def policy_runs(dataset: Path, specs: list[str]) -> list[PolicyRun]:
    """``fallgen table --policy KIND=RUN``: the runs' last checkpoints (or the checkpoint files
    given) as :class:`fallgen.evaluation.table_policies.PolicyRun`, each checked to be of its
    kind and made on ``dataset``; InputError (one line) otherwise, before any work."""
    if not specs:
        return []
    from fallgen.dataset.manifest import sha256 as file_sha256
    from fallgen.evaluation.table_policies import PolicyRun, check_distinct, parse_policies

    try:
        runs = parse_policies(specs)
    except ValueError as e:
        raise InputError("<command line>", "--policy", str(e)) from None
    try:
        from fallgen.policies.runs import dataset_hash, find_checkpoint, load_checkpoint, \
            training_summary
    except ImportError as e:
        raise InputError("<command line>", "--policy", f"needs torch: pip install "
                         f"'fallgen[learn]' ({e})") from None
    digest = dataset_hash(dataset)
    out = []
    for kind, run in runs:
        path = find_checkpoint(run)
        ck = load_checkpoint(path, kind, digest)
        out.append(PolicyRun(kind, path.resolve(), file_sha256(path), training_summary(ck)))
    try:
        check_distinct(out)
    except ValueError as e:
        raise InputError("<command line>", "--policy", str(e)) from None
    return out


__all__ = ["register", "parse_sets", "policy_runs", "MUTABLE"]
