"""bench/audio_distance_cues.py: the room response's direct-to-reverberant ratio falls with
distance in a bare room (the direct sound as 1 / r^2 against a reverberant field that does
not), and the script measures a tiny build's episodes."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

REPO = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(REPO / "bench"))


def test_the_ratio_falls_with_distance_in_a_bare_room(world):
    from audio_distance_cues import rir_drr_db

    from fallgen.audio.room import RoomAcoustics

    room = RoomAcoustics.from_shoebox(world.variant("study_office-l1-m1").shoebox())
    c = np.asarray(room.size_m) / 2
    head = np.array([c[0] - 1.5, c[1], 1.2])
    drr = [rir_drr_db(room, np.array([head[0] + d, c[1], 0.3]), head)
           for d in (0.75, 1.5, 3.0)]
    assert drr[0] > drr[1] > drr[2]
    # 4x the distance: the direct sound 12 dB down, the reverberant field about the same
    assert 6.0 < drr[0] - drr[2] < 14.0, drr


@pytest.mark.xdist_group("tiny_build")
def test_the_script_measures_a_build(tiny_dataset, tmp_path):
    out = tmp_path / "cues.json"
    r = subprocess.run([sys.executable, str(REPO / "bench" / "audio_distance_cues.py"),
                        str(tiny_dataset), "--split", "train", "--json", str(out)],
                       capture_output=True, text=True, timeout=300, check=False)
    assert r.returncode == 0, r.stderr
    d = json.loads(out.read_text())
    assert d["summary"]["episodes"] == len(d["episodes"]) == 2
    for e in d["episodes"]:
        assert np.isfinite(e["rir_drr_db"]) and e["distance_m"] > 0
