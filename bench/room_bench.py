"""Room acoustics speed, side by side with pyroomacoustics 0.10.1, and the image-source order.

    python bench/room_bench.py [--pyroomacoustics PYTHON] [--sofa FILE]

Same room as ``../shared/peers/pyroomacoustics_bench.py`` (6 x 4 x 3 m, source (1.5, 1.2, 1.4),
listener (4.2, 2.6, 1.6), 44.1 kHz, octave-band absorption, air absorption):

- omni image sources at orders 6 / 10 / 17, over the span the order covers (what
  pyroomacoustics computes), and our full 2 s omni response (order 6 + late reverb);
- binaural with the SOFA HRTF: set-up, the image-source part at orders 6 / 10 (pyroomacoustics'
  binaural path at the same order) and the full 2 s binaural response;
- one episode's mix: 20 dry sources of 2 s (a fall's contact groups) into a 2 s clip;
- the order: for every room variant and 50 random source/listener pairs, the lowest order whose
  completeness time (all arrivals of that order in) reaches the perceptual mixing time
  20 V / S + 12 ms (Lindau, Kosanke and Weinzierl, JAES 2012) in 95 % of pairs.

With ``--pyroomacoustics`` (the interpreter ``../shared/peers/setup.sh pyroomacoustics``
prints) the peer runs in the same invocation and ratios are reported. Prints one JSON line.
"""

from __future__ import annotations

import argparse
import json
import platform
import statistics
import subprocess
import time
from pathlib import Path

import numpy as np

from fallgen.audio.hrtf import load_sofa, spherical_head
from fallgen.audio.mix import Binaural, DrySource, Listener
from fallgen.audio.room import (RirSettings, RoomAcoustics, arrivals, completeness_time,
                                omni_rir)
from fallgen.world.library import load_world

SHARED = Path(__file__).resolve().parents[2] / "shared"
PEER = SHARED / "peers" / "pyroomacoustics_bench.py"
DIM, SRC, MIC = (6.0, 4.0, 3.0), (1.5, 1.2, 1.4), (4.2, 2.6, 1.6)
# brickwork-, plasterboard-, glass-, carpet-like octave-band absorption (west..ceiling)
ABSORPTION = np.array([[0.02, 0.02, 0.03, 0.04, 0.05, 0.07, 0.07],
                       [0.02, 0.02, 0.03, 0.04, 0.05, 0.07, 0.07],
                       [0.15, 0.10, 0.06, 0.04, 0.04, 0.05, 0.05],
                       [0.35, 0.25, 0.18, 0.12, 0.07, 0.04, 0.04],
                       [0.07, 0.31, 0.49, 0.81, 0.66, 0.54, 0.54],
                       [0.15, 0.10, 0.06, 0.04, 0.04, 0.05, 0.05]])


def timed(fn, reps: int) -> tuple[float, object]:
    ts, out = [], None
    for _ in range(reps):
        t = time.perf_counter()
        out = fn()
        ts.append(time.perf_counter() - t)
    return 1e3 * statistics.median(ts), out


def order_choice(pairs: int = 50, seed: int = 0) -> dict:
    world = load_world()
    rng = np.random.default_rng(seed)
    need = {}
    for v in world.variants():
        vid = v.id
        room = RoomAcoustics.from_shoebox(v.shoebox())
        s = room.face_areas().sum()
        t_mix = 20 * room.volume_m3 / s / 1000 + 0.012
        lo, hi = np.full(3, 0.3), np.asarray(room.size_m) - 0.3
        for _ in range(pairs):
            a, b = rng.uniform(lo, hi), rng.uniform(lo, hi)
            need.setdefault(vid, []).append(
                next(k for k in range(1, 30) if completeness_time(room, a, b, k) >= t_mix))
    all_needs = np.concatenate(list(need.values()))
    return {"order_95pct": int(np.percentile(all_needs, 95)),
            "order_median": float(np.median(all_needs)), "order_max": int(all_needs.max()),
            "variants": len(need)}


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--pyroomacoustics", help="python of the pyroomacoustics environment")
    ap.add_argument("--sofa", default=str(SHARED / "data" / "hrtf" / "sadie_ku100_48k.sofa"))
    args = ap.parse_args()
    room = RoomAcoustics(DIM, ABSORPTION)
    out: dict = {"bench": "room", "machine": platform.node(), "room": DIM, "fs": 44100}
    for order in (6, 10, 17):
        span = float(arrivals(room, SRC, MIC, order).delay_s.max()) + 0.01
        ms, h = timed(lambda: omni_rir(room, SRC, MIC, None, RirSettings(order, 44100, span),
                                       late=False), 5)
        out[f"omni_order{order}_ms"] = round(ms, 2)
        out[f"omni_order{order}_rir_s"] = round(span, 3)
    out["omni_2s_with_late_ms"] = round(timed(lambda: omni_rir(
        room, SRC, MIC, np.random.default_rng(0)), 5)[0], 2)
    sofa = Path(args.sofa)
    t = time.perf_counter()
    hr = load_sofa(sofa) if sofa.exists() else spherical_head()
    B = Binaural(hr)
    out["binaural_hrtf"] = hr.name
    out["binaural_setup_s"] = round(time.perf_counter() - t, 3)
    head = Listener(np.asarray(MIC), yaw_rad=np.radians(30.0))
    for order in (6, 10):
        s = RirSettings(max_order=order)
        out[f"binaural_order{order}_early_ms"] = round(timed(
            lambda: B.early(room, SRC, head, s), 5)[0], 2)
        out[f"binaural_order{order}_2s_ms"] = round(timed(
            lambda: B.rir(room, SRC, head, np.random.default_rng(0), s), 5)[0], 2)
    rng = np.random.default_rng(1)
    srcs = [DrySource(np.asarray(SRC) + rng.uniform(-0.3, 0.3, 3),
                      rng.standard_normal(88200) * np.exp(-np.arange(88200) / 4000))
            for _ in range(20)]
    out["episode_mix_20_sources_ms"] = round(timed(
        lambda: B.mix(room, srcs, head, np.random.default_rng(0)), 3)[0], 1)
    out["order"] = order_choice()
    if args.pyroomacoustics:
        r = subprocess.run([args.pyroomacoustics, str(PEER), str(sofa)], capture_output=True,
                           text=True, check=True)
        peer = json.loads(r.stdout.strip().splitlines()[-1])
        out["pyroomacoustics"] = peer
        for order in (6, 10, 17):
            out[f"speedup_omni_order{order}"] = round(
                peer[f"omni_order{order}_ms"] / out[f"omni_order{order}_ms"], 2)
        for order in (6, 10):
            out[f"speedup_binaural_order{order}_early"] = round(
                peer[f"binaural_order{order}_ms"] / out[f"binaural_order{order}_early_ms"], 1)
            out[f"speedup_binaural_order{order}_2s"] = round(
                peer[f"binaural_order{order}_ms"] / out[f"binaural_order{order}_2s_ms"], 1)
    print(json.dumps(out))


if __name__ == "__main__":
    main()
