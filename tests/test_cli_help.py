"""What ``--help`` says of the options users asked about: ``evaluate --agent`` takes a file,
``assets modes --workers`` defaults to every core as the other commands do."""

from __future__ import annotations

import os

from typer.testing import CliRunner


def _help(*cmd: str) -> str:
    from fallgen.cli import app

    done = CliRunner().invoke(app, [*cmd, "--help"], env={"COLUMNS": "300", "TERM": "dumb"})
    assert done.exit_code == 0, done.output
    return " ".join(done.output.split())


def test_evaluate_help_names_an_agent_file():
    assert "path/to/file.py:Class" in _help("evaluate")


def test_assets_modes_workers_default_to_every_core(monkeypatch):
    text = _help("assets", "modes")
    assert "default: all cores" in text
    # and the command passes that many to the solver
    import fallgen.audio.catalog as catalog

    seen = {}
    monkeypatch.setattr(catalog, "jobs", lambda world: [])
    monkeypatch.setattr(catalog, "precompute",
                        lambda world, cache_dir=None, workers=1, on_done=None:
                        seen.setdefault("workers", workers))
    from fallgen.cli import app

    done = CliRunner().invoke(app, ["assets", "modes"])
    assert done.exit_code == 0, done.output
    assert seen["workers"] == (os.cpu_count() or 1)
