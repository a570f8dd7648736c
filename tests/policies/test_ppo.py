"""PPO with the oracle found on the tiny build: a few updates through ``fallgen train ppo``,
checkpoints and the log, a resumed run that goes on from its checkpoint (timesteps, the
optimiser's step count, the log's rows), ``fallgen evaluate --agent RUN`` scoring it with the
oracle, a run of another dataset refused, and the encoder's input the wrapper's own."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("sb3_contrib")
pytestmark = pytest.mark.xdist_group("tiny_build")

SMALL = ("--envs", "0", "--set", "n_steps=16", "--set", "batch_size=16", "--set", "n_epochs=1",
         "--set", "checkpoint_every=1", "--set", "lstm_hidden=32")


def _adam_steps(ck) -> float:
    return max(float(s["step"]) for s in ck["state"]["optimizer"]["state"].values())


def test_ppo_trains_resumes_and_is_evaluated(tiny_dataset, tmp_path, cli, capsys):
    import json

    import torch

    from fallgen.dataset.manifest import manifest_sha256
    from fallgen.policies.runs import load_checkpoint, read_log

    run = tmp_path / "ppo"
    assert cli("train", "ppo", str(tiny_dataset), "-o", str(run), "--budget", "32",
               *SMALL) == 0
    cks = sorted((run / "checkpoints").glob("ckpt-*.pt"))
    assert [p.name for p in cks] == ["ckpt-000001.pt", "ckpt-000002.pt"]
    digest = manifest_sha256(tiny_dataset)
    c1, c2 = (load_checkpoint(p, "ppo", digest) for p in cks)
    assert (c1["timesteps"], c2["timesteps"]) == (16, 32)
    changed = [k for k, v in c1["state"]["policy"].items()
               if not torch.equal(v, c2["state"]["policy"][k])]
    assert changed  # an update changed the policy
    rows = read_log(run / "log.csv")
    assert [int(r["update"]) for r in rows] == [1, 2]
    assert (run / "curve.png").stat().st_size > 1000
    # resumed: the same run goes on from update 2 (Adam's step count goes on, the log keeps
    # its rows and adds one)
    assert cli("train", "ppo", str(tiny_dataset), "-o", str(run), "--budget", "48",
               "--envs", "0") == 0
    c3 = load_checkpoint(run / "checkpoints" / "ckpt-000003.pt", "ppo", digest)
    assert c3["timesteps"] == 48
    assert _adam_steps(c3) == _adam_steps(c2) + 1 == 3
    rows3 = read_log(run / "log.csv")
    assert rows3[:2] == rows and int(rows3[2]["update"]) == 3
    # scored as every agent is, with the oracle found: only moves, never a found action
    import fallgen.dataset

    first = fallgen.dataset.open(tiny_dataset).ids("test")[0]
    out = tmp_path / "eval"
    assert cli("evaluate", str(tiny_dataset), "--agent", str(run), "--episodes", str(first),
               "--workers", "1", "-o", str(out)) == 0
    eps = [json.loads(line) for line in (out / "episodes.jsonl").read_text().splitlines()]
    assert [e["episode_id"] for e in eps] == [first]
    assert all(max(e["actions"]) < 5 for e in eps)
    assert all(e["claims"] == 0 for e in eps)
    assert all(e["success"] == (e["outcome"] == "found") for e in eps)
    capsys.readouterr()


def test_a_run_repeats_and_another_datasets_run_is_refused(tiny_dataset, tmp_path, cli,
                                                          capsys):
    """Two runs of one seed make the same weights. A run made on the tiny build, asked to go
    on with a dataset whose manifest differs: one line naming run.json and manifest_sha256,
    exit 2; its checkpoint is refused too."""
    import shutil

    import torch

    from fallgen.errors import InputError
    from fallgen.policies.runs import load_checkpoint

    other = tmp_path / "other"
    other.mkdir()
    for d in ("data", "media"):
        (other / d).symlink_to(tiny_dataset / d)
    for f in tiny_dataset.iterdir():
        if f.is_file():
            shutil.copy(f, other / f.name)
    (other / "manifest.json").write_text((tiny_dataset / "manifest.json").read_text()
                                         .replace("{", "{\n", 1))
    run, twin = tmp_path / "run", tmp_path / "twin"
    for r in (run, twin):
        assert cli("train", "ppo", str(tiny_dataset), "-o", str(r), "--budget", "16",
                   *SMALL) == 0
    a, b = (load_checkpoint(r / "checkpoints" / "ckpt-000001.pt", "ppo") for r in (run, twin))
    assert all(torch.equal(v, b["state"]["policy"][k]) for k, v in a["state"]["policy"].items())
    capsys.readouterr()
    assert cli("train", "ppo", str(other), "-o", str(run), "--budget", "32") == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "run.json: manifest_sha256" in err, err
    from fallgen.dataset.manifest import manifest_sha256

    ck = run / "checkpoints" / "ckpt-000001.pt"
    with pytest.raises(InputError, match="ckpt-000001.pt: manifest_sha256"):
        load_checkpoint(ck, "ppo", manifest_sha256(other))
    with pytest.raises(InputError, match="kind"):
        load_checkpoint(ck, "dt")


def test_the_agent_sees_what_training_saw(tiny_dataset):
    """The evaluated agent's conversion of the environment's own observations equals the
    training wrapper's, and the encoder reads both batched as the policy does."""
    import torch

    from fallgen.env import FallenObjectsEnv
    from fallgen.env.wrappers import CompactObservation
    from fallgen.policies import SENSORS
    from fallgen.policies.encoder import FEATURES_DIM, ObservationEncoder, compactor, \
        to_tensors

    raw = FallenObjectsEnv(tiny_dataset, "test", sensors=SENSORS)
    wrapped = CompactObservation(FallenObjectsEnv(tiny_dataset, "test", sensors=SENSORS))
    try:
        sr = int(raw.ds.row(raw.ids[0])["sample_rate"])
        mine = compactor(sr)
        o, _ = raw.reset(seed=0)
        w, _ = wrapped.reset(seed=0)
        for step in range(3):
            if step:
                o, *_ = raw.step(1)
                w, *_ = wrapped.step(1)
            c = mine(o, first=step == 0)
            assert set(c) == set(w)
            for k in w:
                assert np.array_equal(c[k], w[k]), k
        enc = ObservationEncoder()
        t = to_tensors({k: np.stack([c[k], w[k]]) for k in c})
        assert t["rgb"].shape == (2, 3, 84, 84) and t["category_seg"].shape == (2, 1, 84, 84)
        with torch.no_grad():
            f = enc(t)
        assert f.shape == (2, FEATURES_DIM) and torch.equal(f[0], f[1])
    finally:
        raw.close()
        wrapped.close()



def test_the_table_scores_a_trained_run_beside_the_random_walk(tiny_dataset, tmp_path, cli,
                                                               capsys):
    """``fallgen table --policy ppo=RUN``: Table 1 gains the run's row (labelled with what its
    training spent, the paper's PPO beside it) and the random walk with the oracle found; the
    row is the run scored by ``fallgen evaluate`` on the same episodes; a rerun keeps it, a
    newer checkpoint runs it again; a malformed or foreign run is refused in one line."""
    import json

    run = tmp_path / "ppo"
    assert cli("train", "ppo", str(tiny_dataset), "-o", str(run), "--budget", "16",
               *SMALL) == 0
    out = tmp_path / "table"
    args = ("table", str(tiny_dataset), "-o", str(out), "--trees", "5", "--workers", "1",
            "--no-vision", "--episodes", "2", "--policy", f"ppo={run}")
    assert cli(*args) == 0
    data = json.loads((out / "table.json").read_text())
    md = (out / "table.md").read_text()
    assert {"ppo", "random_oracle_found"} <= set(data["results"])
    assert "PPO (oracle found, 16 environment steps, 0 min)" in md
    assert "0.19 / 0.15 / 0.14" in md and "Random walk (oracle found)" in md
    assert data["policy_training"]["ppo"]["steps"] == 16
    row = [json.loads(x) for x in (out / "rows" / "ppo" / "episodes.jsonl").read_text()
           .splitlines()]
    ids = [e["episode_id"] for e in row]
    ev = tmp_path / "eval"
    assert cli("evaluate", str(tiny_dataset), "--agent", str(run), "--episodes",
               ",".join(map(str, ids)), "--workers", "1", "-o", str(ev)) == 0
    alone = [json.loads(x) for x in (ev / "episodes.jsonl").read_text().splitlines()]
    assert [e["actions"] for e in alone] == [e["actions"] for e in row]
    summary = out / "rows" / "ppo" / "summary.json"
    before = summary.stat().st_mtime_ns
    assert cli(*args) == 0
    assert summary.stat().st_mtime_ns == before  # kept
    assert cli("train", "ppo", str(tiny_dataset), "-o", str(run), "--budget", "32") == 0
    assert cli(*args) == 0
    assert summary.stat().st_mtime_ns != before  # the run's newer checkpoint: run again
    assert json.loads(summary.read_text())["checkpoint_sha256"] != \
        data["policy_training"]["ppo"]["sha256"]
    capsys.readouterr()
    for bad in (("ppo",), (f"sac={run}",), (f"dt={run}",),
                (f"ppo={run}", "--policy", f"ppo={run}")):
        assert cli(*args[:-1], *bad) == 2
        err = capsys.readouterr().err.strip()
        assert len(err.splitlines()) == 1, err


def test_a_run_of_one_room_kind_is_scored_on_the_other_in_table_2(tiny_dataset, tmp_path, cli,
                                                                  capsys):
    """``fallgen table --policy ppo=RUN`` with a run trained on the kitchens alone
    (``--room-kind kitchen``): Table 2 gains its row on the study rooms' test episodes, beside
    the run of both kinds on the same rooms; two runs of one kind on the same rooms are
    refused in one line."""
    import json

    from fallgen.dataset.reader import Dataset

    both, kitchen = tmp_path / "both", tmp_path / "kitchen"
    assert cli("train", "ppo", str(tiny_dataset), "-o", str(both), "--budget", "16",
               *SMALL) == 0
    assert cli("train", "ppo", str(tiny_dataset), "-o", str(kitchen), "--budget", "16",
               "--room-kind", "kitchen", *SMALL) == 0
    out = tmp_path / "table"
    args = ("table", str(tiny_dataset), "-o", str(out), "--trees", "5", "--workers", "1",
            "--no-vision", "--episodes", "2", "--cross-episodes", "0")
    assert cli(*args, "--policy", f"ppo={both}", "--policy", f"ppo={kitchen}") == 0
    data = json.loads((out / "table.json").read_text())
    assert {"ppo", "ppo_kitchen_to_study"} <= set(data["results"])
    assert data["policy_training"]["ppo_kitchen_to_study"]["settings"]["room_kind"] == "kitchen"
    assert data["policy_training"]["ppo"]["settings"]["room_kind"] is None

    def ids(key):
        rows = (out / "rows" / key / "episodes.jsonl").read_text().splitlines()
        return [json.loads(x)["episode_id"] for x in rows]

    study = {r["episode_id"] for r in Dataset(tiny_dataset).rows("test", "study")}
    assert study and set(ids("ppo_kitchen_to_study")) == study
    md = (out / "table.md").read_text()
    table2 = md[md.index("## Table 2"):md.index("## The audio module")]
    assert "PPO (oracle found, kitchen -> study, 16 environment steps, 0 min)" in table2
    assert "study rooms, trained on both kinds" in table2
    capsys.readouterr()
    checkpoint = sorted((kitchen / "checkpoints").glob("*.pt"))[-1]  # the same run, named apart
    assert cli(*args, "--policy", f"ppo={kitchen}", "--policy", f"ppo={checkpoint}") == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "kitchen rooms" in err, err
