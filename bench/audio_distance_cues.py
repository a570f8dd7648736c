"""Is the direct-to-reverberant ratio a distance cue in a build's clips, and does the audio
module use it? Per episode of a split: the room's omnidirectional impulse response from where
the object came to rest to the agent's head (the generator's own acoustics,
:func:`fallgen.audio.room.omni_rir`), its DRR (the direct sound, from 1 ms before to 2.5 ms
after r / c, against the rest), and the clip's own direct-sound share (the audio features'
``direct_l`` / ``direct_r``: log10 of the energy in the first 5 ms from the onset over
5-80 ms); Spearman rank correlations with the true horizontal distance per room variant
(median over rooms with >= 8 episodes), pooled, and by zone kind; the DRR's slope against
log10 distance. With ``--audio-model``: the distance regressor's importance of each of those
features and their rank among all.

    python bench/audio_distance_cues.py DATASET [--split test] [--episodes 1000]
        [--audio-model M] [--json OUT.json]
"""

from __future__ import annotations

import argparse
import collections
import json
import math
import sys
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO / "src"))

from fallgen.audio.room import RirSettings, RoomAcoustics, omni_rir  # noqa: E402
from fallgen.nav.agent import AgentSpec  # noqa: E402
from fallgen.perception.audio_features import AudioFeatures  # noqa: E402


def rir_drr_db(room: RoomAcoustics, source, listener, fs: int = 44100) -> float:
    """DRR (dB) of the omni response from ``source`` to ``listener``: the energy from 1 ms
    before to 2.5 ms after the direct sound's arrival against all that follows."""
    h = omni_rir(room, source, listener, np.random.default_rng(0), RirSettings(length_s=1.0))
    k = int(round(float(np.linalg.norm(np.subtract(source, listener))) / room.c * fs))
    a, b = max(0, k - int(0.001 * fs)), k + int(0.0025 * fs)
    return 10 * math.log10((h[a:b] ** 2).sum() / max(float((h[b:] ** 2).sum()), 1e-30))


def measure(ds, rows, world) -> list[dict]:
    cam = AgentSpec().camera_height_m
    rooms: dict[str, RoomAcoustics] = {}
    feats = None
    out = []
    for r in rows:
        v = r["room_variant"]
        if v not in rooms:
            rooms[v] = RoomAcoustics.furnished(world.variant(v), world.materials)
        room = rooms[v]
        src = np.clip(np.asarray(r["settle_pos"], float), 0.01, np.asarray(room.size_m) - 0.01)
        lis = np.array([r["spawn_x"], r["spawn_y"], cam])
        audio = ds.arrays(r, ("audio",))["audio"]
        if feats is None:
            feats = AudioFeatures(clip_samples=audio.shape[1])
        f = feats.extract(audio)
        names = feats.names
        out.append({"episode_id": int(r["episode_id"]), "room": v, "zone": r["zone_kind"],
                    "distance_m": math.hypot(src[0] - lis[0], src[1] - lis[1]),
                    "rir_drr_db": rir_drr_db(room, src, lis),
                    "clip_direct": float(f[names.index("direct_l")]
                                         + f[names.index("direct_r")]) / 2})
    return out


def correlations(out: list[dict]) -> dict:
    from scipy.stats import spearmanr

    def rho(sel, key):
        x = [out[i][key] for i in sel]
        return float(spearmanr(x, [out[i]["distance_m"] for i in sel])[0]) if len(sel) > 3 \
            else float("nan")

    by_room, by_zone = collections.defaultdict(list), collections.defaultdict(list)
    for i, o in enumerate(out):
        by_room[o["room"]].append(i)
        by_zone[o["zone"]].append(i)
    rooms = [s for s in by_room.values() if len(s) >= 8]
    every = list(range(len(out)))
    logd = np.log10([o["distance_m"] for o in out])
    drr = np.array([o["rir_drr_db"] for o in out])
    fit = np.polyfit(logd, drr, 1)
    return {
        "episodes": len(out), "rooms_with_8": len(rooms),
        "rir_drr": {"pooled": rho(every, "rir_drr_db"),
                    "median_per_room": float(np.median([rho(s, "rir_drr_db") for s in rooms]))
                    if rooms else float("nan"),
                    "slope_db_per_decade": float(fit[0]),
                    "residual_sd_db": float(np.std(drr - np.polyval(fit, logd)))},
        "clip_direct": {"pooled": rho(every, "clip_direct"),
                        "median_per_room": float(np.median([rho(s, "clip_direct")
                                                            for s in rooms]))
                        if rooms else float("nan")},
        "by_zone_kind": {z: {"n": len(s), "rir_drr": rho(s, "rir_drr_db"),
                             "clip_direct": rho(s, "clip_direct")}
                         for z, s in sorted(by_zone.items())},
    }


def importance(model_path: Path) -> dict:
    from fallgen.perception.audio_model import AudioModel

    m = AudioModel.load(model_path)
    imp = m.distance_model.feature_importances_
    order = list(np.argsort(-imp))
    names = m.features.names
    return {n: {"importance": float(imp[names.index(n)]),
                "rank": order.index(names.index(n)) + 1, "of": len(names)}
            for n in ("direct_l", "direct_r", "peak_db", "rms_db")}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("dataset")
    ap.add_argument("--split", default="test")
    ap.add_argument("--episodes", type=int, default=1000, help="evenly spaced; 0: all")
    ap.add_argument("--audio-model", type=Path)
    ap.add_argument("--json", type=Path)
    a = ap.parse_args()
    from fallgen.dataset.reader import Dataset
    from fallgen.world.library import load_world

    ds = Dataset(a.dataset)
    rows = sorted(ds.rows(a.split), key=lambda r: r["episode_id"])
    if a.episodes and a.episodes < len(rows):
        rows = [rows[i] for i in np.linspace(0, len(rows) - 1, a.episodes).astype(int)]
    out = measure(ds, rows, load_world(None))
    res = correlations(out)
    if a.audio_model:
        res["distance_model_importance"] = importance(a.audio_model)
    print(json.dumps(res, indent=1))
    if a.json:
        a.json.write_text(json.dumps({"summary": res, "episodes": out}, indent=1) + "\n")


if __name__ == "__main__":
    main()
