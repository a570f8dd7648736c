"""The documentation's shell commands name what exists. Every ```bash / ```sh block of
README.md and docs/*.md is read line by line (continuations joined, comments and
``[optional]`` parts dropped): a ``fallgen`` command (also inside ``sbatch --wrap '...'``) must
be a command of the command line and each ``--option`` one of its options (its ``--help``
lists it); a ``make`` target must be a target of the Makefile; a ``python bench/*.py`` script
must exist and take its ``--options``. Most of these commands need a paper-size build or a
cluster to run; the Python blocks run as written (tests/evaluation/test_readme.py)."""

from __future__ import annotations

import re
import shlex
from functools import cache
from pathlib import Path

import pytest
from typer.testing import CliRunner

REPO = Path(__file__).resolve().parents[1]
DOCS = [REPO / "README.md", *sorted((REPO / "docs").glob("*.md"))]
SHELL = re.compile(r"^```(?:bash|sh|shell|console)\n(.*?)^```", re.S | re.M)


def shell_lines(paths=DOCS) -> list[tuple[str, str]]:
    """(``file:line``, command) of every command line of the shell blocks of ``paths``."""
    out = []
    for p in paths:
        text = p.read_text()
        for m in SHELL.finditer(text):
            first = text.count("\n", 0, m.start()) + 2
            joined = m.group(1).replace("\\\n", " ")
            for k, line in enumerate(joined.splitlines()):
                line = re.sub(r"\[[^\]]*\]", " ", line)  # [--optional parts]
                line = re.sub(r"(^|\s)#.*$", "", line).strip()
                if line:
                    out.append((f"{p.relative_to(REPO)}:{first + k}", line))
    return out


def commands(line: str) -> list[list[str]]:
    """The commands of a line: itself split into words, and any quoted ``--wrap`` command of
    it (``&&`` splits commands too); a leading ``.venv/bin/`` is dropped."""
    line = re.sub(r"\$\(([^()]*)\)", r"\1", line)  # r=$(sbatch ...): the inner command
    line = re.sub(r"^\w+=", "", line)
    words = shlex.split(line)
    out, cur = [], []
    for w in words:
        if w in ("&&", "||", ";", "|", ">", ">>"):
            out.append(cur)
            cur = []
            continue
        cur.append(w)
    out.append(cur)
    for i, w in enumerate(words):
        if w == "--wrap" and i + 1 < len(words):
            out += commands(words[i + 1])
    return [[w.removeprefix(".venv/bin/") for w in c] for c in out if c]


@cache
def fallgen_help(*path: str) -> str | None:
    """``fallgen PATH --help``, or None when PATH is no command."""
    from fallgen.cli import app

    done = CliRunner().invoke(app, [*path, "--help"], env={"COLUMNS": "300", "TERM": "dumb"})
    return done.output if done.exit_code == 0 else None


def check_fallgen(words: list[str]) -> list[str]:
    """What is wrong with ``fallgen WORDS`` (empty: nothing)."""
    args = words[1:]
    path: list[str] = []
    for w in args:  # the longest run of leading words that is a command group or command
        if w.startswith("-") or fallgen_help(*path, w) is None:
            break
        path.append(w)
    if not path:
        return [f"{' '.join(words)}: no such command"]
    text = fallgen_help(*path)
    if re.search(r"\bCommands\b", text) and len(path) == len(args):
        return []  # a group shown with its commands
    options = {a.split("=", 1)[0] for a in args if a.startswith("--")}
    return [f"fallgen {' '.join(path)}: no option {o}" for o in sorted(options)
            if not re.search(rf"(^|[\s,│|]){re.escape(o)}([\s,│|=]|$)", text, re.M)]


@cache
def make_targets() -> set[str]:
    text = (REPO / "Makefile").read_text()
    return set(re.findall(r"^([A-Za-z][\w-]*)\s*:(?!=)", text, re.M))


def check(words: list[str]) -> list[str]:
    if words[0] == "fallgen":
        return check_fallgen(words)
    if words[0] == "make":
        return [f"make {t}: no such target" for t in words[1:]
                if "=" not in t and not t.startswith("-") and t not in make_targets()]
    if words[0] in ("python", "python3") and len(words) > 1 and words[1].startswith("bench/"):
        script = REPO / words[1]
        if not script.is_file():
            return [f"{words[1]}: no such script"]
        text = script.read_text()
        return [f"{words[1]}: no option {o}" for o in words[2:]
                if o.startswith("--") and f'"{o.split("=", 1)[0]}"' not in text]
    return []  # another program (sbatch, python -m mujoco.viewer, ...)


LINES = shell_lines()


def test_the_documentation_has_shell_commands():
    """The extraction finds the README's commands, so a change of the fence syntax cannot
    make the test below check nothing."""
    names = [c[0] for _, line in LINES for c in commands(line)]
    assert names.count("make") >= 3 and names.count("fallgen") >= 20


@pytest.mark.parametrize("where,line", LINES, ids=[w for w, _ in LINES])
def test_each_documented_command_names_what_exists(where, line):
    problems = [p for c in commands(line) for p in check(c)]
    assert not problems, f"{where}: {line}: {problems}"


def test_the_check_rejects_what_does_not_exist():
    assert check(["fallgen", "evaluate", "DATASET", "--baseline", "expert"]) == []
    assert check(["fallgen", "evaluate", "DATASET", "--no-such-option", "1"])
    assert check(["fallgen", "no-such-command", "x"])
    assert check(["fallgen", "rooms", "acoustics", "'*'", "--raytrace"]) == []
    assert check(["fallgen", "rooms", "acoustics", "x", "--ray-trace"])
    assert check(["make", "table"]) == [] and check(["make", "tables"])
    assert check(["python", "bench/policy_bench.py", "--steps", "3"]) == []
    assert check(["python", "bench/policy_bench.py", "--stepz", "3"])
    assert check(["python", "bench/no_such.py"])
    assert commands("g=$(sbatch --wrap 'fallgen generate -c x && fallgen validate y')")[-2:] \
        == [["fallgen", "generate", "-c", "x"], ["fallgen", "validate", "y"]]
