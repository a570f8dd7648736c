"""The benchmark's commands (``fallgen evaluate``, ``fallgen export-expert``): a thin layer over
:mod:`fallgen.evaluation`, registered on the main app by :mod:`fallgen.cli`."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Annotated, Optional

import typer
from rich.console import Console
from rich.table import Table

from fallgen.errors import InputError

#: Message starts of the selection's ValueErrors -> the option they are about.
_FIELDS = (("split", "--split"), ("room_kind", "--room-kind"), ("no episode of category",
           "--category"), ("no episode ", "--episodes"), ("cross_scene", "--cross-scene"),
           ("no actions", "--actions"), ("rank", "--workers"))


def _field(message: str, default: str) -> str:
    for start, option in _FIELDS:
        if message.startswith(start):
            return option
    return default


def parse_ids(text: str | None) -> list[int] | None:
    """``"3,7,10-12"`` -> [3, 7, 10, 11, 12]; None for None."""
    if text is None:
        return None
    ids: list[int] = []
    try:
        for part in text.split(","):
            part = part.strip()
            if not part:
                continue
            if "-" in part[1:]:
                a, b = part.split("-", 1) if not part.startswith("-") else (part, "")
                ids += list(range(int(a), int(b) + 1))
            else:
                ids.append(int(part))
    except ValueError:
        raise InputError("<command line>", "--episodes", f"{text!r}: expected ids such as "
                         "3,7,10-12") from None
    if not ids:
        raise InputError("<command line>", "--episodes", f"{text!r}: no episode id")
    return ids


def _open(dataset: Path):
    from fallgen.dataset.reader import Dataset

    try:
        return Dataset(dataset)
    except FileNotFoundError as e:
        raise InputError(dataset, "data/", str(e).split(": ", 1)[-1]) from None


def _agent_ref(agent: str | None, agent_kwargs: str | None, actions: Path | None,
               baseline: str | None, oracles: str | None, audio_model: Path | None = None,
               audio_top_k: int = 1, ds=None, vision_model: Path | None = None,
               device: str = "cpu"):
    import json

    from fallgen.agents import BASELINES, ORACLES
    from fallgen.evaluation.evaluate import load_actions
    from fallgen.evaluation.runner import AgentRef, load_factory

    given = [n for n, v in (("--agent", agent), ("--actions", actions), ("--baseline", baseline))
             if v is not None]
    if len(given) != 1:
        raise InputError("<command line>", "--agent", "give exactly one of --agent "
                         "module:factory, --actions FILE, --baseline NAME"
                         + (f" (got {', '.join(given)})" if given else ""))
    if oracles is not None and baseline not in ("modular", "objectgoal"):
        raise InputError("<command line>", "--oracles", "only for --baseline modular or "
                         "objectgoal")
    if audio_model is not None and baseline != "modular":
        raise InputError("<command line>", "--audio-model", "only for --baseline modular")
    if vision_model is not None and baseline not in ("modular", "objectgoal"):
        raise InputError("<command line>", "--vision-model", "only for --baseline modular "
                         "or objectgoal")
    if agent is not None:
        kwargs = {}
        if agent_kwargs:
            try:
                kwargs = json.loads(agent_kwargs)
            except json.JSONDecodeError:
                kwargs = None
            if not isinstance(kwargs, dict):
                raise InputError("<command line>", "--agent-kwargs", "expected a JSON object")
        from fallgen.policies.agent import is_run

        if is_run(agent):  # a run of fallgen train, or one of its checkpoints
            agent, kwargs = "fallgen.policies.agent:load_run", {"run": agent, **kwargs}
        try:
            load_factory(agent)  # fail here, in one line, not in a worker
        except ValueError as e:
            raise InputError("<command line>", "--agent", str(e)) from None
        return AgentRef("factory", agent, kwargs=kwargs)
    if actions is not None:
        try:
            return AgentRef("actions", actions=load_actions(actions))
        except ValueError as e:
            file, _, msg = str(e).partition(": ")
            raise InputError(file, "actions", msg) from None
    if baseline not in BASELINES:
        raise InputError("<command line>", "--baseline", f"{baseline!r}: one of "
                         f"{', '.join(BASELINES)}")
    chosen: tuple[str, ...] = ()
    if baseline == "modular":  # default: every oracle; with a vision model, none
        chosen = (ORACLES if vision_model is None else ()) if oracles is None else \
            tuple(o.strip() for o in oracles.split(",") if o.strip() and o.strip() != "none")
        bad = sorted(set(chosen) - set(ORACLES))
        if bad:
            raise InputError("<command line>", "--oracles", f"{bad[0]!r}: choose from "
                             f"{', '.join(ORACLES)} (or none)")
        chosen = tuple(o for o in ORACLES if o in chosen)
    if baseline == "objectgoal":
        chosen = tuple(o.strip() for o in (oracles or "").split(",")
                       if o.strip() and o.strip() != "none")
        bad = sorted(set(chosen) - {"segmentation"})
        if bad:
            raise InputError("<command line>", "--oracles", f"{bad[0]!r}: Object-Goal "
                             "takes only segmentation (or none)")
        if not chosen and vision_model is None:
            raise InputError("<command line>", "--vision-model", "Object-Goal needs eyes: "
                             "--vision-model FILE or --oracles segmentation")
    if vision_model is not None and "segmentation" in chosen:
        raise InputError("<command line>", "--vision-model", "the agent's eyes where the "
                         "segmentation oracle is off: drop one of --vision-model and "
                         "--oracles segmentation")
    kwargs: dict = {}
    if audio_model is not None:
        _check_audio_model(audio_model, ds)
        kwargs = {"audio_model": str(audio_model), "audio_top_k": int(audio_top_k)}
    if vision_model is not None:
        from fallgen.cli_vision import device_name, load_model

        load_model(vision_model, ds)  # one line here for a bad file, not in every worker
        kwargs["vision_model"] = str(vision_model)
        if device != "cpu":
            kwargs["vision_device"] = device_name(device)
    return AgentRef("baseline", baseline, oracles=chosen, kwargs=kwargs)


def _check_audio_model(path: Path, ds) -> None:
    """Load the model once here (a one-line error for a bad file, or for a dataset whose clips
    it was not made for: ``ds``, an open dataset) rather than in every worker."""
    from fallgen.perception.audio_model import AudioModel, check_features

    model = AudioModel.load(path)
    if ds is not None:
        rows = ds.rows(ds.splits[0]) if ds.splits else []
        if rows:
            check_features(ds, rows[:1], model.features, path, model.hrtf)


def register(app: typer.Typer, console: Console) -> None:
    @app.command()
    def evaluate(
        dataset: Annotated[Path, typer.Argument(help="A dataset directory.")],
        out: Annotated[Path, typer.Option("--out", "-o", help="Directory for episodes.jsonl "
                                          "and summary.json.")],
        split: Annotated[Optional[str], typer.Option(
            help="train, validation, test, or all (default: test; all the episodes given "
            "by --episodes or --actions when either is).", show_default=False)] = None,
        room_kind: Annotated[Optional[str], typer.Option(
            help="kitchen or study only.")] = None,
        cross_scene: Annotated[Optional[str], typer.Option(
            help="kitchen_to_study (test on the study rooms) or study_to_kitchen (on the "
            "kitchens): the paper's Table 2.")] = None,
        episodes: Annotated[Optional[str], typer.Option(
            help="Only these episode ids, e.g. 3,7,10-12.")] = None,
        category: Annotated[Optional[str], typer.Option(
            help="Only these object categories (comma-separated).")] = None,
        agent: Annotated[Optional[str], typer.Option(
            help="Your agent: module:factory or path/to/file.py:Class, a callable returning "
            "an object with reset() and act(obs) -> int (see README).")] = None,
        agent_kwargs: Annotated[Optional[str], typer.Option(
            help="JSON object of keyword arguments for the factory.")] = None,
        actions: Annotated[Optional[Path], typer.Option(
            help="Re-score action sequences: a JSON object of episode id -> list of actions, or an "
            "episodes.jsonl.")] = None,
        baseline: Annotated[Optional[str], typer.Option(
            help="A reference agent: expert, random, modular, objectgoal.")] = None,
        oracles: Annotated[Optional[str], typer.Option(
            help="The modular agent's oracles: any of segmentation,category,location, or "
            "none (default: all three; none with --vision-model). Object-Goal's: "
            "segmentation or none (default).")] = None,
        audio_model: Annotated[Optional[Path], typer.Option(
            help="The modular agent's goal predictor where an oracle is off: a model file "
            "of fallgen audio-model train (category and where the fall was heard).")] = None,
        audio_top_k: Annotated[int, typer.Option(
            min=1, help="With --audio-model: the agent takes an object of any of the model's "
            "k likeliest categories for the fallen one.")] = 1,
        vision_model: Annotated[Optional[Path], typer.Option(
            help="The modular or objectgoal agent's eyes where the segmentation oracle is "
            "off: a model file of fallgen vision-model train.")] = None,
        device: Annotated[str, typer.Option(
            help="Where --vision-model runs: cpu (default) or cuda (when present).")] = "cpu",
        workers: Annotated[Optional[int], typer.Option(
            min=1, help="Worker processes (default: all cores).", show_default=False)] = None,
        claims: Annotated[int, typer.Option(min=1, help="found claims allowed (2: the "
                                            "original challenge).")] = 1,
        reward: Annotated[str, typer.Option(help="paper or geodesic (the return only).")
                          ] = "paper",
        seed: Annotated[int, typer.Option(help="Seeds the agents' per-episode "
                                          "generators.")] = 0,
        data_dir: Annotated[Optional[Path], typer.Option(
            "--data-dir", help="World data the dataset was built with (default: built-in).",
            show_default=False)] = None,
    ) -> None:
        """Score an agent on a dataset's episodes: success, SPL, SNA (95 % intervals) in the
        paper's Table 1 layout; every episode in OUT/episodes.jsonl, the summary in
        OUT/summary.json."""
        from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, \
            TimeElapsedColumn

        from fallgen.evaluation.evaluate import evaluate as run, write
        from fallgen.evaluation.scores import PAPER_TABLE1, PAPER_TABLE2

        ds = _open(dataset)
        ids = parse_ids(episodes)
        ref = _agent_ref(agent, agent_kwargs, actions, baseline, oracles, audio_model,
                         audio_top_k, ds, vision_model, device)
        if reward not in ("paper", "geodesic"):
            raise InputError("<command line>", "--reward", f"{reward!r}: paper or geodesic")
        cats = [c.strip() for c in category.split(",") if c.strip()] if category else None
        n_workers = workers if workers is not None else (os.cpu_count() or 1)
        if split is None:
            split = "all" if ids is not None or ref.kind == "actions" else "test"
            if ref.kind == "actions" and ids is None and cross_scene is None \
                    and room_kind is None and not cats:
                ids = sorted(ref.actions or {})  # the file's episodes
        with Progress(TextColumn("evaluate"), BarColumn(), MofNCompleteColumn(),
                      TimeElapsedColumn(), console=console) as bar:
            task = bar.add_task("", total=None)
            try:
                ev = run(dataset, ref, split=None if split == "all" else split,
                         room_kind=room_kind, cross_scene=cross_scene, categories=cats,
                         episode_ids=ids, workers=n_workers, claims=claims, reward=reward,
                         seed=seed, data_dir=data_dir,
                         on_selected=lambda n: bar.update(task, total=n),
                         progress=lambda n: bar.update(task, advance=n))
            except ValueError as e:
                raise InputError("<command line>", _field(str(e), "--agent"), str(e)) from None
            except (FileNotFoundError, KeyError) as e:
                raise InputError(dataset, "data/", str(e).strip("'\"")) from None
        paths = write(ev, out)
        s = ev.summary
        title = f"{s['agent']} on {dataset}: {s['n']} episodes" + (
            f" ({cross_scene})" if cross_scene else f" (split {split}"
            + (f", {room_kind}" if room_kind else "") + ")")
        t = Table("Method", "SR", "SPL", "SNA", "soft SPL", title=title)
        ci = s["ci95"]
        t.add_row(s["agent"], *[f"{s[m]:.3f} [{ci[m][0]:.2f}, {ci[m][1]:.2f}]"
                                for m in ("success", "spl", "sna", "soft_spl")])
        ref_rows = [PAPER_TABLE2[cross_scene]] if cross_scene else PAPER_TABLE1
        for name, sr, spl, sna in ref_rows:
            t.add_row(f"[dim]paper: {name}[/dim]", f"[dim]{sr:.2f}[/dim]", f"[dim]{spl:.2f}[/dim]",
                      f"[dim]{sna:.2f}[/dim]", "")
        console.print(t)
        kinds = Table("room kind", "n", "SR", "SPL", "SNA")
        for k, v in s["by_room_kind"].items():
            kinds.add_row(k, str(v["n"]), f"{v['success']:.3f}", f"{v['spl']:.3f}",
                          f"{v['sna']:.3f}")
        console.print(kinds)
        o = s["outcomes"]
        console.print(f"outcomes: found {o['found']}, wrong found {o['wrong_found']}, timeout "
                      f"{o['timeout']}; {s['mean_steps']:.1f} actions on average; "
                      f"object seen in {s['seen_share']:.0%} of episodes")
        console.print(f"{paths[0]}, {paths[1]}")

    @app.command("export-expert")
    def export_expert(
        dataset: Annotated[Path, typer.Argument(help="A dataset directory.")],
        out: Annotated[Path, typer.Option("--out", "-o", help="Output directory.")],
        split: Annotated[Optional[str], typer.Option(
            help="train, validation, test, or all (default: train; all the episodes given by "
            "--episodes when it is).", show_default=False)] = None,
        room_kind: Annotated[Optional[str], typer.Option(help="kitchen or study only.")] = None,
        episodes: Annotated[Optional[str], typer.Option(
            help="Only these episode ids, e.g. 3,7,10-12.")] = None,
        sensors: Annotated[str, typer.Option(
            help="Observations to keep (comma-separated; oracle sensors allowed).")
        ] = "rgb,depth,audio,pose",
        fmt: Annotated[str, typer.Option("--format", help="hdf5 (OUT/expert.h5) or minari "
                                         "(a Minari dataset under OUT).")] = "hdf5",
        dataset_id: Annotated[str, typer.Option(help="Minari dataset id.")
                              ] = "fallgen/expert-v0",
        data_dir: Annotated[Optional[Path], typer.Option(
            "--data-dir", help="World data the dataset was built with (default: built-in).",
            show_default=False)] = None,
    ) -> None:
        """The expert's trajectories with every step's observation, for imitation learning:
        each episode's expert_actions replayed through the environment."""
        from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, \
            TimeElapsedColumn

        from fallgen.env.fallen_objects import SENSORS
        from fallgen.env.source import select
        from fallgen.evaluation.trajectories import FORMATS, export_expert as run

        ds = _open(dataset)
        chosen = tuple(s.strip() for s in sensors.split(",") if s.strip())
        bad = [s for s in chosen if s not in SENSORS]
        if bad or not chosen:
            raise InputError("<command line>", "--sensors", f"{(bad or [sensors])[0]!r}: "
                             f"choose from {', '.join(SENSORS)}")
        if fmt not in FORMATS:
            raise InputError("<command line>", "--format", f"{fmt!r}: one of "
                             f"{', '.join(FORMATS)}")
        wanted = parse_ids(episodes)
        if split is None:
            split = "all" if wanted is not None else "train"
        try:
            ids = select(ds, None if split == "all" else split, room_kind, None, wanted)
        except ValueError as e:
            raise InputError("<command line>", _field(str(e), "--split"), str(e)) from None
        with Progress(TextColumn("export"), BarColumn(), MofNCompleteColumn(),
                      TimeElapsedColumn(), console=console) as bar:
            task = bar.add_task("", total=len(ids))
            try:  # the user's mistakes are InputErrors naming their file or option
                path = run(dataset, out, ids, chosen, fmt, dataset_id, data_dir,
                           progress=lambda n: bar.update(task, advance=n))
            except ValueError as e:  # the dataset and the environment disagree
                raise InputError(dataset, "data/", str(e)) from None
        console.print(f"{len(ids)} expert trajectories -> {path}")

    @app.command("table")
    def table_cmd(
        dataset: Annotated[Path, typer.Argument(help="A dataset directory (a paper-size build: "
                                                "make dataset).")],
        out: Annotated[Path, typer.Option("--out", "-o", help="Directory for table.md, "
                                          "table.json, the rows, models and audio scores.")
                       ] = Path("build/table"),
        episodes: Annotated[int, typer.Option(
            min=0, help="Test episodes per Table 1 row (a seeded subsample; 0: all).")] = 300,
        cross_episodes: Annotated[int, typer.Option(
            min=0, help="Test episodes of each room kind for Table 2 (0: all).")] = 200,
        workers: Annotated[Optional[int], typer.Option(
            min=1, help="Worker processes (default: all cores).", show_default=False)] = None,
        seed: Annotated[int, typer.Option(help="Seeds the subsample, the audio models and "
                                          "the agents.")] = 0,
        trees: Annotated[int, typer.Option(min=1, help="Trees per audio model.")] = 300,
        vision: Annotated[bool, typer.Option(
            "--vision/--no-vision", help="Train the visual module (needs fallgen[learn]) and "
            "run the rows that use it.")] = True,
        vision_frames: Annotated[int, typer.Option(
            min=1, help="The visual module's training frames (vision-model train --frames).")
        ] = 24000,
        vision_epochs: Annotated[int, typer.Option(
            min=1, help="The visual module's epochs (vision-model train --epochs).")] = 4,
        vision_model: Annotated[Optional[Path], typer.Option(
            help="Use this visual module (fallgen vision-model train on this dataset) "
            "instead of training one.")] = None,
        device: Annotated[str, typer.Option(help="Where the visual module trains and is "
                                            "scored: cpu or cuda.")] = "cpu",
        policy: Annotated[Optional[list[str]], typer.Option(
            "--policy", help="KIND=RUN (repeatable; KIND: dt, ppo, savi): score this trained "
            "run (fallgen train) in Table 1, or in Table 2 on the other room kind when it "
            "learned on one alone (--room-kind), labelled with its training's budget.",
            show_default=False)] = None,
        data_dir: Annotated[Optional[Path], typer.Option(
            "--data-dir", help="World data the dataset was built with (default: built-in).",
            show_default=False)] = None,
    ) -> None:
        """The paper's Table 1 (random, the learned policies given, Object-Goal, the modular
        agent with the learned audio and visual modules and the paper's oracle ablations, the
        expert) and Table 2 (the audio module, or a policy given, learned on one room kind,
        tested on the other) with 95 % intervals, into OUT/table.md; reruns keep what is done."""
        from fallgen.cli_common import step_bars
        from fallgen.cli_train import policy_runs
        from fallgen.evaluation.table import make_table

        _open(dataset)
        policies = policy_runs(dataset, list(policy or []))
        if vision:
            from fallgen.cli_vision import device_name

            device = device_name(device)
        elif vision_model is not None:
            raise InputError("<command line>", "--vision-model", "not with --no-vision")
        with step_bars(console) as progress:
            try:
                run = make_table(dataset, out, episodes=episodes, cross_episodes=cross_episodes,
                                 workers=workers or (os.cpu_count() or 1), seed=seed,
                                 trees=trees, data_dir=data_dir, vision=vision,
                                 vision_frames=vision_frames, vision_epochs=vision_epochs,
                                 device=device, vision_model=vision_model,
                                 policies=policies, log=console.print, progress=progress)
            except ValueError as e:
                raise InputError(dataset, _field(str(e), "data/"), str(e)) from None
        console.print((out / "table.md").read_text())
        console.print(f"{len(run.results)} rows in {run.timings['total'] / 60:.1f} min -> "
                      f"{out / 'table.md'}")

    from fallgen import cli_vision

    cli_vision.register(app, console)

    audio_app = typer.Typer(help="The auditory perception module: train it on a "
                            "build's train split, score it on another.", no_args_is_help=True)
    app.add_typer(audio_app, name="audio-model")

    def _rows(ds, split: str, room_kind: Optional[str], option: str = "--split") -> list[dict]:
        if split not in ds.splits:
            raise InputError("<command line>", option, f"{split!r}: the dataset has "
                             f"{', '.join(ds.splits) or 'no split'}")
        rows = ds.rows(split, room_kind)
        if not rows:
            raise InputError("<command line>", "--room-kind", f"no {room_kind} episode in "
                             f"the {split} split")
        return rows

    def _bar(label: str):
        from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, \
            TimeElapsedColumn

        return Progress(TextColumn(label), BarColumn(), MofNCompleteColumn(),
                        TimeElapsedColumn(), console=console)

    @audio_app.command("train")
    def audio_train(
        dataset: Annotated[Path, typer.Argument(help="A dataset directory.")],
        out: Annotated[Path, typer.Option("--out", "-o", help="The model file to write.")],
        split: Annotated[str, typer.Option(help="The split it learns from.")] = "train",
        room_kind: Annotated[Optional[str], typer.Option(
            help="kitchen or study only (cross-scene: train on one, score on the other).")
        ] = None,
        seed: Annotated[int, typer.Option(help="The trees' seed.")] = 0,
        trees: Annotated[int, typer.Option(help="Trees per model.", min=1)] = 300,
    ) -> None:
        """Learn the category, the audio material and where the fall was from the step-0
        clips of a split; save the model with its feature settings."""
        from fallgen.perception.audio_model import AudioModel

        ds = _open(dataset)
        rows = _rows(ds, split, room_kind)
        with _bar("features") as bar:
            task = bar.add_task("", total=len(rows))
            model = AudioModel.train(ds, rows, seed=seed, trees=trees,
                                     progress=lambda n: bar.update(task, advance=n))
        model.meta.update({"split": split, "room_kind": room_kind, "dataset": str(dataset)})
        model.save(out)
        console.print(f"audio model on {len(rows)} {split} episodes "
                      f"({model.features.sample_rate} Hz, {model.features.clip_samples} "
                      f"samples, {len(model.features.names)} features; position error "
                      f"{model.position_error_m:.2f} m out of bag) -> {out}")

    @audio_app.command("eval")
    def audio_eval(
        dataset: Annotated[Path, typer.Argument(help="A dataset directory.")],
        model_path: Annotated[Path, typer.Option("--model", "-m", help="A model file "
                                                 "(fallgen audio-model train).")],
        out: Annotated[Path, typer.Option("--out", "-o", help="Directory for scores.json and "
                                          "the confusion matrices' PNGs.")],
        split: Annotated[str, typer.Option(help="The split it is scored on.")] = "test",
        room_kind: Annotated[Optional[str], typer.Option(help="kitchen or study only.")
                             ] = None,
        train_split: Annotated[str, typer.Option(
            help="The split the no-audio prior's frequencies come from.")] = "train",
    ) -> None:
        """Score a model on a split: category top-1 / top-5, material accuracy, median
        azimuth error, distance rank correlation, against chance and a prior that does not
        listen; by zone kind and distance; confusion matrices as PNGs."""
        import json

        from fallgen.atomic import write_bytes
        from fallgen.perception.audio_model import AudioModel, check_features, confusion_png, \
            evaluate
        from fallgen.world.library import load_world

        ds = _open(dataset)
        model = AudioModel.load(model_path)
        rows = _rows(ds, split, room_kind)
        check_features(ds, rows, model.features, model_path, model.hrtf)
        train_rows = _rows(ds, train_split, None, "--train-split")
        with _bar("features") as bar:
            task = bar.add_task("", total=len(rows))
            scores, confusion = evaluate(model, ds, rows, train_rows, load_world(),
                                         progress=lambda n: bar.update(task, advance=n))
        scores.update({"split": split, "room_kind": room_kind, "model": str(model_path),
                       "trained_on": model.meta, "trained_manifest_sha256":
                       model.manifest_sha256})
        out.mkdir(parents=True, exist_ok=True)
        write_bytes(out / "scores.json", (json.dumps(scores, indent=1) + "\n").encode())
        for name, (matrix, labels) in confusion.items():
            confusion_png(matrix, labels, name, out / f"confusion_{name}.png")
        table = Table(title=f"audio model on {len(rows)} {split} episodes")
        for col in ("", "model", "prior (no audio)", "chance"):
            table.add_column(col)
        for key, fmt in (("category_top1", "{:.3f}"), ("category_top5", "{:.3f}"),
                         ("material_top1", "{:.3f}"), ("azimuth_median_error_deg", "{:.1f}"),
                         ("lateral_median_error_deg", "{:.1f}"),
                         ("front_back_confusion_rate", "{:.3f}"),
                         ("distance_rank_correlation", "{:.3f}"),
                         ("distance_rank_correlation_within_room", "{:.3f}"),
                         ("distance_rank_correlation_told_room", "{:.3f}"),
                         ("distance_rank_correlation_within_room_told_room", "{:.3f}")):
            cells = [scores.get(key), scores["prior"].get(key), scores["chance"].get(key)]
            table.add_row(key, *("" if v is None else fmt.format(v) for v in cells))
        console.print(table)
        console.print(f"position median error {scores['position_median_error_m']:.2f} m; "
                      f"-> {out / 'scores.json'}, confusion_category.png, "
                      "confusion_material.png")
