"""``fallgen train --device cuda``: each policy trains a few steps on the GPU and its run is
played on the CPU (skipped without a CUDA device); without one, the option is refused in
one line."""

from __future__ import annotations

import pytest

torch = pytest.importorskip("torch")
pytest.importorskip("sb3_contrib")
pytestmark = pytest.mark.xdist_group("tiny_build")

SMALL = {
    "ppo": ("--envs", "0", "--budget", "32", "--set", "n_steps=16", "--set", "batch_size=16",
            "--set", "n_epochs=1", "--set", "lstm_hidden=32"),
    "dt": ("--budget", "4", "--set", "context=4", "--set", "embed=32", "--set", "layers=1",
           "--set", "heads=2", "--set", "batch_size=4", "--set", "eval_every=0"),
    "savi": ("--envs", "0", "--budget", "32", "--set", "n_steps=16", "--set", "batch_size=16",
             "--set", "n_epochs=1", "--set", "memory=3", "--set", "embed=32", "--set",
             "heads=2", "--set", "layers=1", "--set", "goal_epochs=20"),
}


@pytest.mark.skipif(not torch.cuda.is_available(), reason="no CUDA device")
def test_each_policy_trains_on_cuda_and_plays_on_the_cpu(tiny_dataset, tmp_path, cli):
    from fallgen.env import FallenObjectsEnv
    from fallgen.policies import SENSORS
    from fallgen.policies.agent import load_run
    from fallgen.policies.runs import Run, load_checkpoint

    env = FallenObjectsEnv(tiny_dataset, "test", sensors=SENSORS)
    try:
        obs, _ = env.reset(seed=0)
        for kind, extra in SMALL.items():
            run = tmp_path / kind
            assert cli("train", kind, str(tiny_dataset), "-o", str(run), "--device", "cuda",
                       *extra) == 0, kind
            ck = load_checkpoint(Run(run).latest(), kind, device="cpu")
            state = ck["state"]["policy" if kind != "dt" else "model"]
            assert all(v.device.type == "cpu" for v in state.values())
            agent = load_run(run)  # on the CPU
            agent.reset(seed=0)
            assert 0 <= agent.act(obs) < 6
    finally:
        env.close()


@pytest.mark.skipif(torch.cuda.is_available(), reason="a CUDA device is here")
def test_cuda_without_a_device_is_refused(tiny_dataset, tmp_path, cli, capsys):
    assert cli("train", "ppo", str(tiny_dataset), "-o", str(tmp_path / "run"), "--device",
               "cuda") == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "--device" in err and "no CUDA" in err, err
    assert not (tmp_path / "run").exists()
