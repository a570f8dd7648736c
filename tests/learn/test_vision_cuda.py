"""``fallgen vision-model train --device cuda``: the visual module trains a step on the GPU,
its file loads on the CPU and predicts there as on the GPU (skipped without a CUDA device);
without one, the option is refused in one line and nothing is written."""

from __future__ import annotations

import numpy as np
import pytest

torch = pytest.importorskip("torch")
pytestmark = pytest.mark.xdist_group("tiny_build")

TRAIN = ("--frames", "9", "--epochs", "1", "--crop", "64", "--batch", "4", "--val-episodes",
         "1", "--workers", "1", "--threads", "1", "--seed", "1")


@pytest.mark.skipif(not torch.cuda.is_available(), reason="no CUDA device")
def test_vision_model_trains_on_cuda_and_predicts_alike_on_the_cpu(tiny_dataset, tmp_path, cli):
    import fallgen.dataset
    from fallgen.learn.vision_model import VisionModel

    model = tmp_path / "v.model"
    assert cli("vision-model", "train", str(tiny_dataset), "-o", str(model), "--device", "cuda",
               *TRAIN) == 0
    m = VisionModel.load(model)
    assert m.meta["device"] == "cuda"
    ep = fallgen.dataset.open(tiny_dataset).get(fallgen.dataset.open(tiny_dataset).ids()[0])
    rgb, depth = ep["rgb"][None], np.asarray(ep["depth"], np.float32)[None]
    best_cpu, lead_cpu = m.scores(rgb, depth, "cpu")
    # in full float32 on the GPU too: its convolutions run in TF32 by default (a 10-bit
    # mantissa; on an H200 the margins then differed by ~3e-3 of values ~2)
    tf32 = torch.backends.cudnn.allow_tf32, torch.backends.cuda.matmul.allow_tf32
    torch.backends.cudnn.allow_tf32 = torch.backends.cuda.matmul.allow_tf32 = False
    try:
        best_gpu, lead_gpu = m.scores(rgb, depth, "cuda")
    finally:
        torch.backends.cudnn.allow_tf32, torch.backends.cuda.matmul.allow_tf32 = tf32
    assert lead_cpu.shape == lead_gpu.shape
    assert np.allclose(lead_cpu, lead_gpu, rtol=1e-4, atol=1e-4), \
        float(np.abs(lead_cpu - lead_gpu).max())
    # the best class may flip only where two classes' scores tie within that rounding
    assert (best_cpu == best_gpu).mean() >= 0.99


@pytest.mark.skipif(torch.cuda.is_available(), reason="a CUDA device is here")
def test_vision_model_cuda_without_a_device_is_refused(tiny_dataset, tmp_path, cli, capsys):
    model = tmp_path / "v.model"
    assert cli("vision-model", "train", str(tiny_dataset), "-o", str(model), "--device", "cuda",
               *TRAIN) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "--device" in err, err
    assert not model.exists()
