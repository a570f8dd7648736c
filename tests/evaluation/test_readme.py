"""The documentation's code runs as written. Every ```python block of README.md and docs/*.md
runs as a script of its own (``python block.py``) in a directory where ``demo`` and
``build/smoke`` are the tiny build; a block that needs a paper-size build says so with a
comment line ``# needs: paper-size build`` and is skipped. The README's agent example is also
given to ``fallgen evaluate --agent file.py:Class`` and must find some of the tiny build's
objects; the modular baseline runs through the command line, with all oracles and with
none."""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

pytestmark = pytest.mark.xdist_group("tiny_build")

REPO = Path(__file__).resolve().parents[2]
README = REPO / "README.md"
DOCS = [README, *sorted((REPO / "docs").glob("*.md"))]
NEEDS_FULL = "# needs: paper-size build"
#: Dataset paths the documentation's blocks use, each made the tiny build where they run.
DATASET_PATHS = ("demo", "build/smoke")
BLOCK = re.compile(r"^```python\n(.*?)^```", re.S | re.M)


def python_blocks(paths=DOCS) -> list[tuple[str, str]]:
    """(``file:line``, code) of every ```python block of ``paths``."""
    out = []
    for p in paths:
        text = p.read_text()
        for m in BLOCK.finditer(text):
            line = text.count("\n", 0, m.start()) + 1
            out.append((f"{p.relative_to(REPO)}:{line}", m.group(1)))
    return out


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
