"""The ray tracer's reverberation of every room variant, traced once and shipped: writes
``src/fallgen/audio/rays_mid.json`` (:data:`fallgen.audio.acoustics.TRACED_MID`), which
``fallgen stats`` judges the reverberation goal on.

    python bench/rays_table.py [--rooms '*'] [--out src/fallgen/audio/rays_mid.json]

For each variant: the model's RT60 (what the renderer decays at, and what a dataset's rows
carry) and the ray tracer's T30 and T20 at 500 Hz and 1 kHz, with
:data:`~fallgen.audio.acoustics.RAYS_PER_BAND` rays a band from the variant's own seed (the rays
of :func:`fallgen.audio.acoustics.rt60_checks`). ~20 s a variant on one core of the 2-core
development VM, ~20 min for the 64. Run it again when a room, a material's absorption or the
furniture changes (``tests/audio/test_rt60_goal.py`` fails while the table is stale).
"""

from __future__ import annotations

import argparse
import datetime
import fnmatch
import json
import platform
import time
from pathlib import Path

import numpy as np
from tqdm import tqdm

from fallgen.audio.acoustics import MID_BANDS, RAYS_PER_BAND, TRACED_MID, room_report
from fallgen.world.materials import OCTAVE_BANDS_HZ
from fallgen.world.library import load_world
from provenance import cpu_model  # bench/, beside this script


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--rooms", default="*", help="variant ids (glob)")
    ap.add_argument("--out", type=Path, default=TRACED_MID)
    a = ap.parse_args()
    world = load_world()
    variants = [v for v in world.variants() if fnmatch.fnmatch(v.id, a.rooms)]
    mid = list(MID_BANDS)
    table, t0 = {}, time.time()
    for v in tqdm(variants, desc="variants", unit="variant"):
        r = room_report(v, world.materials, raytrace=True, bands=mid)
        table[v.id] = {"model_s": r.rt60_s[mid].tolist(),
                       "t30_s": np.asarray(r.raytrace_t30_s)[mid].tolist(),
                       "t20_s": np.asarray(r.raytrace_t20_s)[mid].tolist()}
    out = {"what": "the ray tracer's T30 and T20 at 500 Hz and 1 kHz of each room variant, "
                   "beside the model RT60 it was traced with (s)",
           "bands_hz": [OCTAVE_BANDS_HZ[i] for i in mid], "rays_per_band": RAYS_PER_BAND,
           "command": "python bench/rays_table.py"
                      + ("" if a.rooms == "*" else f" --rooms '{a.rooms}'"),
           "date": datetime.datetime.fromtimestamp(t0, datetime.timezone.utc).strftime(
               "%Y-%m-%d %H:%M UTC"),
           "machine": {"cpu": cpu_model(), "python": platform.python_version()},
           "seconds": round(time.time() - t0, 1), "variants": table}
    a.out.write_text(json.dumps(out, indent=1) + "\n")
    print(f"{len(table)} variants -> {a.out}")


if __name__ == "__main__":
    main()
