"""The README's benchmark examples run as written (on the tiny build): the environment
snippet, and the Agent example as a file given to ``fallgen evaluate --agent file.py:Class``;
the modular baseline through the command line, with all oracles and with none."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

pytestmark = pytest.mark.xdist_group("tiny_build")

README = Path(__file__).resolve().parents[2] / "README.md"


def _blocks() -> tuple[str, str]:
    text = README.read_text()
    section = text[text.index("## The benchmark"):]
    env_block = re.search(r"```python\n(.*?)```", section, re.S).group(1)
    agent = section[section.index("<!-- agent-example"):]
    agent_block = re.search(r"```python\n(.*?)```", agent, re.S).group(1)
    return env_block, agent_block


def test_readme_environment_snippet_runs(tiny_dataset):
    env_block, _ = _blocks()
    code = env_block.replace('"build/smoke"', repr(str(tiny_dataset)))
    assert code != env_block
    scope: dict = {}
    exec(compile(code, str(README), "exec"), scope)
    try:
        assert scope["info"]["step"] == 1 and scope["obs"]["rgb"].shape == (300, 300, 3)
        assert scope["vec"].num_envs == 2
    finally:
        scope["vec"].close()
        scope["env"].close()


def _check_look_around(recs: list[dict], summary: dict) -> None:
    """What the README's LookAround does, episode by episode: turn left 11 times, step
    forward, again, until it claims (action 5, only as its last) or runs out of 200 actions;
    the summary's success rate is the episodes' mean."""
    for r in recs:
        acts = r["actions"]
        claimed = acts[-1] == 5
        walk = acts[:-1] if claimed else acts
        assert walk == [0 if (k + 1) % 12 == 0 else 1 for k in range(len(walk))], r["actions"]
        assert r["steps"] == len(acts)
        if claimed:
            assert r["outcome"] in ("found", "wrong_found") and r["success"] == \
                (r["outcome"] == "found")
        else:
            assert len(acts) == 200 and r["outcome"] == "timeout" and not r["success"]
    assert summary["success"] == pytest.approx(sum(r["success"] for r in recs) / len(recs))
    assert summary["n"] == len(recs)


def test_readme_agent_example_evaluates_from_its_file(tiny_dataset, tmp_path, cli):
    _, agent_block = _blocks()
    f = tmp_path / "my_agent.py"
    f.write_text(agent_block)
    assert cli("evaluate", str(tiny_dataset), "--split", "all", "--agent", f"{f}:LookAround",
               "-o", str(tmp_path / "look"), "--workers", "2") == 0
    recs = [json.loads(x) for x in (tmp_path / "look" / "episodes.jsonl").read_text()
            .splitlines()]
    assert len(recs) == 6
    s = json.loads((tmp_path / "look" / "summary.json").read_text())
    assert s["agent"].endswith("my_agent.py:LookAround")
    _check_look_around(recs, s)
    # the check rejects the actions of another agent (the random baseline's) and a summary
    # that is not its episodes' mean
    assert cli("evaluate", str(tiny_dataset), "--split", "all", "--baseline", "random",
               "-o", str(tmp_path / "random"), "--workers", "1") == 0
    other = [json.loads(x) for x in (tmp_path / "random" / "episodes.jsonl").read_text()
             .splitlines()]
    with pytest.raises(AssertionError):
        _check_look_around(other, s)
    with pytest.raises(AssertionError):
        _check_look_around(recs, dict(s, success=1.0 - s["success"] + 0.01))
    # a broken file: one line naming it, exit 2
    bad = tmp_path / "broken.py"
    bad.write_text("class X(:\n")
    assert cli("evaluate", str(tiny_dataset), "--agent", f"{bad}:X", "-o", str(tmp_path / "b")) == 2


def test_modular_baseline_from_the_command_line(tiny_dataset, tmp_path, cli, capsys):
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
