"""The version lives in one place, ``fallgen.__version__``: the package metadata reads it,
``fallgen --version`` prints it, a build's manifest records it, and CHANGELOG.md's newest
release is it."""

from __future__ import annotations

import re
import tomllib
from pathlib import Path

from typer.testing import CliRunner

import fallgen

REPO = Path(__file__).resolve().parents[1]


def test_pyproject_reads_the_version_from_the_package():
    meta = tomllib.loads((REPO / "pyproject.toml").read_text())
    assert "version" not in meta["project"] and "version" in meta["project"]["dynamic"]
    assert meta["tool"]["hatch"]["version"]["path"] == "src/fallgen/__init__.py"
    assert re.fullmatch(r"\d+\.\d+\.\d+", fallgen.__version__)


def test_the_command_line_and_the_manifest_say_it():
    from fallgen.cli import app
    from fallgen.dataset.manifest import versions

    done = CliRunner().invoke(app, ["--version"])
    assert done.exit_code == 0
    assert done.output.startswith(f"fallgen {fallgen.__version__} (mujoco ")
    assert versions()["fallgen"] == fallgen.__version__


def test_the_changelogs_newest_release_is_this_version():
    releases = re.findall(r"^## \[(\d+\.\d+\.\d+)\] - \d{4}-\d\d-\d\d$",
                          (REPO / "CHANGELOG.md").read_text(), re.M)
    assert releases and releases[0] == fallgen.__version__
