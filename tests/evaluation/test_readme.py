"""The documentation's code runs as written. Every ```python block of README.md and docs/*.md
runs as a script of its own (``python block.py``) in a directory where ``demo`` and
``build/smoke`` are the tiny build; a block that needs a paper-size build says so with a
comment line ``# needs: paper-size build`` and is skipped. The README's agent example is also
given to ``fallgen evaluate --agent file.py:Class`` and must find some of the tiny build's
objects; the modular baseline runs through the command line, with all oracles and with
none.

Every ```bash / ```sh block's commands name what exists (most need a paper-size build or a
cluster to run): read line by line (continuations joined, comments and ``[optional]`` parts
dropped), a ``fallgen`` command (also inside ``sbatch --wrap '...'``) must be a command of the
command line and each ``--option`` one of its options (its ``--help`` lists it); a ``make``
target a target of the Makefile; a ``python bench/*.py`` script must exist and take its
``--options``."""

from __future__ import annotations

import json
import os
import re
import shlex
import subprocess
import sys
from functools import cache
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

pytestmark = pytest.mark.xdist_group("tiny_build")

REPO = Path(__file__).resolve().parents[2]
README = REPO / "README.md"
DOCS = [README, *sorted((REPO / "docs").glob("*.md"))]
NEEDS_FULL = "# needs: paper-size build"
#: Dataset paths the documentation's blocks use, each made the tiny build where they run.
DATASET_PATHS = ("demo", "build/smoke")
BLOCK = re.compile(r"^```python\n(.*?)^```", re.S | re.M)
SHELL = re.compile(r"^```(?:bash|sh|shell|console)\n(.*?)^```", re.S | re.M)


def fenced_blocks(fence: re.Pattern, paths=DOCS) -> list[tuple[Path, int, str]]:
    """(file, line of the opening fence, body) of every block of ``paths`` that ``fence``
    matches."""
    out = []
    for p in paths:
        text = p.read_text()
        for m in fence.finditer(text):
            out.append((p, text.count("\n", 0, m.start()) + 1, m.group(1)))
    return out


def python_blocks(paths=DOCS) -> list[tuple[str, str]]:
    """(``file:line``, code) of every ```python block of ``paths``."""
    return [(f"{p.relative_to(REPO)}:{line}", code)
            for p, line, code in fenced_blocks(BLOCK, paths)]


def run_block(code: str, where: Path, timeout: float = 600) -> subprocess.CompletedProcess:
    """``code`` as a script of its own in ``where`` (Hugging Face's caches under it, offline)."""
    script = where / "block.py"
    script.write_text(code)
    env = {**os.environ, "HF_HOME": str(where / ".hf"), "HF_DATASETS_OFFLINE": "1",
           "HF_HUB_OFFLINE": "1"}
    return subprocess.run([sys.executable, script.name], cwd=where, env=env, text=True,
                          capture_output=True, timeout=timeout)


BLOCKS = python_blocks()


def test_the_documentation_has_python_blocks():
    """The extraction finds the README's blocks (the dataset example, the environment, the
    agent), so a change of the fence syntax cannot make the test below run nothing."""
    readme = [c for w, c in BLOCKS if w.startswith("README.md")]
    assert len(readme) >= 3
    assert any("class LookAround" in c for c in readme)
    assert any("make_vec" in c for c in readme)


@pytest.mark.parametrize("where,code", BLOCKS, ids=[w for w, _ in BLOCKS])
def test_python_block_runs_as_a_script(where, code, tiny_dataset, tmp_path):
    if NEEDS_FULL in code:
        pytest.skip("needs a paper-size build")
    for rel in DATASET_PATHS:
        link = tmp_path / rel
        link.parent.mkdir(parents=True, exist_ok=True)
        link.symlink_to(tiny_dataset, target_is_directory=True)
    done = run_block(code, tmp_path)
    assert done.returncode == 0, f"{where}:\n{done.stderr[-3000:]}"


def test_a_failing_block_is_reported(tmp_path):
    """The runner sees a block that fails (the check above can fail)."""
    assert run_block("import sys\nsys.exit(3)\n", tmp_path).returncode == 3
    assert run_block("raise ValueError('x')\n", tmp_path).returncode != 0
    assert run_block("import numpy\n", tmp_path).returncode == 0


def _agent_block() -> str:
    text = README.read_text()
    section = text[text.index("<!-- agent-example"):]
    return BLOCK.search(section).group(1)


def _replay(tiny_dataset, agent_cls, eid: int) -> list[int]:
    """The agent's actions in episode ``eid``, stepped by hand through the environment (not
    the evaluation's workers): what its evaluation must have recorded."""
    from fallgen.env import FallenObjectsEnv

    env = FallenObjectsEnv(tiny_dataset, sensors=agent_cls.sensors)
    agent, acts = agent_cls(), []
    try:
        obs, _ = env.reset(options={"episode_id": eid})
        agent.reset()
        while True:
            a = int(agent.act(obs))
            acts.append(a)
            obs, _, term, trunc, _ = env.step(a)
            if term or trunc:
                return acts
    finally:
        env.close()


def test_readme_agent_example_finds_objects_from_its_file(tiny_dataset, tmp_path, cli):
    """``fallgen evaluate --agent my_agent.py:LookAround`` on every episode: each episode's
    actions are the agent's own (stepped by hand through the environment), it succeeds in some
    episodes, and each claim it makes is judged as the environment judges it."""
    f = tmp_path / "my_agent.py"
    f.write_text(_agent_block())
    assert cli("evaluate", str(tiny_dataset), "--split", "all", "--agent", f"{f}:LookAround",
               "-o", str(tmp_path / "look"), "--workers", "2") == 0
    recs = [json.loads(x) for x in (tmp_path / "look" / "episodes.jsonl").read_text()
            .splitlines()]
    s = json.loads((tmp_path / "look" / "summary.json").read_text())
    assert len(recs) == 6 and s["agent"].endswith("my_agent.py:LookAround")
    scope: dict = {}
    exec(compile(_agent_block(), "my_agent.py", "exec"), scope)
    for r in recs:
        assert r["actions"] == _replay(tiny_dataset, scope["LookAround"], r["episode_id"])
        if r["actions"][-1] == 5:
            assert r["success"] == (r["distance_to_object_m"] <= 2.0)
    assert s["success"] == pytest.approx(np.mean([r["success"] for r in recs]))
    assert s["success"] > 0, [(r["outcome"], r["distance_to_object_m"]) for r in recs]
    # the random baseline's actions are not the agent's (the replay check can fail)
    assert cli("evaluate", str(tiny_dataset), "--split", "all", "--baseline", "random",
               "-o", str(tmp_path / "random"), "--workers", "1") == 0
    other = json.loads((tmp_path / "random" / "episodes.jsonl").read_text().splitlines()[0])
    assert other["actions"] != _replay(tiny_dataset, scope["LookAround"], other["episode_id"])
    # a broken file: one line naming it, exit 2
    bad = tmp_path / "broken.py"
    bad.write_text("class X(:\n")
    assert cli("evaluate", str(tiny_dataset), "--agent", f"{bad}:X", "-o", str(tmp_path / "b")) == 2


def test_modular_baseline_from_the_command_line(tiny_dataset, tmp_path, cli):
    assert cli("evaluate", str(tiny_dataset), "--split", "all", "--baseline", "modular",
               "-o", str(tmp_path / "all"), "--workers", "1") == 0
    s = json.loads((tmp_path / "all" / "summary.json").read_text())
    assert s["agent"] == "modular[segmentation+category+location]"
    assert s["success"] >= 5 / 6
    assert cli("evaluate", str(tiny_dataset), "--split", "all", "--baseline", "modular",
               "--oracles", "none", "-o", str(tmp_path / "none"), "--workers", "1") == 0
    s0 = json.loads((tmp_path / "none" / "summary.json").read_text())
    assert s0["agent"] == "modular" and s0["success"] < s["success"]
    assert s0["outcomes"]["timeout"] == 6


# --- the shell blocks ------------------------------------------------------------------

def shell_lines(paths=DOCS) -> list[tuple[str, str]]:
    """(``file:line``, command) of every command line of the shell blocks of ``paths``."""
    out = []
    for p, fence, body in fenced_blocks(SHELL, paths):
        joined = body.replace("\\\n", " ")
        for k, line in enumerate(joined.splitlines()):
            line = re.sub(r"\[[^\]]*\]", " ", line)  # [--optional parts]
            line = re.sub(r"(^|\s)#.*$", "", line).strip()
            if line:
                out.append((f"{p.relative_to(REPO)}:{fence + 1 + k}", line))
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
