"""``fallgen stats DATASET``: what a dataset holds, from its Parquet rows alone.

Counts by split and room kind, category, audio material and zone kind; expert lengths; the
distribution of audio levels at the ear; and where the episodes come from compared with the
rehearsed events: events unusable for an episode (no pose sees the object, the replay diverged)
are replaced by others of the same split and room kind, so zone kinds that are hard to see from
the robot's camera are under-represented. ``bias`` reports each zone kind's share of the
episodes against its share of the rehearsed events, and the skip reasons by zone kind.
"""

from __future__ import annotations

import json
from collections import Counter
from pathlib import Path

import numpy as np
import pyarrow.parquet as pq

from fallgen.audio import AUDIO_ENERGY_CEILING
from fallgen.audio.acoustics import RT60_GOAL_S, rt60_goal
from fallgen.config import SPLITS
from fallgen.dataset.writer import shard_meta

COLUMNS = ["episode_id", "event_id", "split", "room_kind", "room_variant", "category",
           "audio_material", "zone_kind", "expert_actions", "expert_path_m", "shortest_path_m",
           "audio_peak_db_spl", "audio_leq_db_spl", "event_attempts", "skipped_events",
           "spawn_sees_object"]
#: read when present (datasets built before they existed lack them)
OPTIONAL = ["audio_energy_ratio", "fall_height_m", "room_rt60_s", "first_impact_surface"]
#: The paper's audio materials: every one should be a target's.
AUDIO_MATERIALS = 14
#: Physical goals a paper-size build is checked against: the share of the fall's
#: lost energy its sound radiates (at most a few per cent, for ringing thin-walled bodies; the
#: median of hard objects' falls onto hard surfaces within what measured hard impacts radiate,
#: ~1e-4 to 1e-2: Koss & Alfredson 1973, Akay 1978; light objects, soft floors and soft bodies
#: radiate far less, and no range is measured for them), the level heard at the agent (a fall
#: heard from 2-6 m in a home), each zone kind's level against the floor's, and the audio
#: materials of the targets.
GOALS = {"energy_ratio_ceiling": AUDIO_ENERGY_CEILING,
         "energy_ratio_median_hard": (1e-4, 1e-2),
         "peak_db_spl": (35.0, 125.0), "peak_db_spl_p5_p95": (55.0, 110.0),
         "zone_median_vs_floor_db": 15.0, "material_min_share": 0.01, "min_fall_m": 0.3,
         # furnished dwellings' mid-frequency (500 Hz-1 kHz) reverberation time
         # (fallgen.audio.acoustics.RT60_GOAL_S, its sources there)
         "rt60_mid_s": RT60_GOAL_S}
#: The hard impacts of :data:`GOALS`' energy median: a target of one of these audio materials
#: whose first impact strikes a bare surface of one of them (a finish after "/" is no bare
#: hard surface: a gypsum board, an appliance's sheet metal).
HARD_MATERIALS = frozenset({"metal", "glass", "ceramic", "stone", "wood_hard"})
PERCENTILES = (5, 25, 50, 75, 95)
#: Goals about the distribution of the episodes, judged only on a build with at least this many
#: (a smoke or demo build cannot meet them): a share of 1 % needs 100 episodes to be one
#: episode, the 5th and 95th percentiles 100 to be more than the extremes, a zone kind's
#: median a few episodes of each kind, a median 20 to be more than a few falls (the energy
#: median: 20 hard impacts).
MIN_EPISODES = {"audio_materials": 100, "peak_db_spl_p5_p95": 100,
                "zone_median_vs_floor": 100, "energy_ratio_median_hard": 20}


def _summary(x) -> dict:
    x = np.asarray(x, float)
    if not len(x):
        return {"n": 0}
    return {"n": int(len(x)), "mean": float(x.mean()),
            **{f"p{q}": float(np.percentile(x, q)) for q in PERCENTILES},
            "min": float(x.min()), "max": float(x.max())}


def _split_order(split: str) -> tuple[int, str]:
    return (SPLITS.index(split) if split in SPLITS else len(SPLITS), split)


def _sorted(c: Counter) -> dict:
    return dict(sorted(c.items(), key=lambda kv: (-kv[1], kv[0])))


def _rt60_by_variant(rows: list[dict]) -> dict[str, list[float]]:
    """Each room variant's RT60 per band (one per variant: its episodes all carry it)."""
    return {r["room_variant"]: r["room_rt60_s"] for r in rows if r.get("room_rt60_s")}


def stats(root: str | Path) -> dict:
    root = Path(root)
    rows, dropped = [], []
    for p in sorted((root / "data").glob("*.parquet")):
        names = set(pq.read_schema(p).names)
        t = pq.read_table(p, columns=COLUMNS + [c for c in OPTIONAL if c in names]) \
            if pq.read_metadata(p).num_rows else None
        if t is not None:
            rows += t.to_pylist()
        dropped += (shard_meta(pq.read_schema(p)) or {}).get("dropped", [])
    events: dict[str, str] = {}
    for p in sorted((root / "rehearsal").glob("*.parquet")):
        t = pq.read_table(p, columns=["event_id", "zone_kind"])
        events.update(zip(t.column(0).to_pylist(), t.column(1).to_pylist()))

    out: dict = {"episodes": len(rows), "dropped_episodes": len(dropped)}
    out["by_split"] = {s: dict(sorted(Counter(r["room_kind"] for r in rows
                                              if r["split"] == s).items()))
                       for s in sorted({r["split"] for r in rows}, key=_split_order)}
    out["room_variants"] = len({r["room_variant"] for r in rows})
    for key in ("category", "audio_material", "zone_kind"):
        out[f"by_{key}"] = _sorted(Counter(r[key] for r in rows))
    n_actions = [len(r["expert_actions"]) for r in rows]
    looks = [sum(a in (3, 4) for a in r["expert_actions"]) for r in rows]
    out["expert"] = {"actions": _summary(n_actions), "path_m": _summary(
        [r["expert_path_m"] for r in rows]), "shortest_path_m": _summary(
        [r["shortest_path_m"] for r in rows]), "episodes_that_look_up_or_down":
        int(sum(n > 0 for n in looks))}
    out["audio_db_spl"] = {"peak": _summary([r["audio_peak_db_spl"] for r in rows]),
                           "leq_125ms": _summary([r["audio_leq_db_spl"] for r in rows])}
    edges = np.arange(0, 150, 10)
    hist, _ = np.histogram([r["audio_leq_db_spl"] for r in rows], bins=edges)
    out["audio_db_spl"]["leq_125ms_histogram"] = {f"{a}-{a + 10}": int(h)
                                                  for a, h in zip(edges[:-1], hist) if h}
    # per audio material: the share of the lost energy the sound carries and the level heard
    # (what a material's median says of its physics; impacts of hard bodies on hard floors
    # radiate ~1e-4 to 1e-2, soft bodies and carpets far less)
    by_mat: dict[str, list[tuple[float, float]]] = {}
    for r in rows:
        if np.isfinite(r.get("audio_energy_ratio", np.nan)):
            by_mat.setdefault(r["audio_material"], []).append(
                (r["audio_energy_ratio"], r["audio_peak_db_spl"]))
    by_mat_summary = {
        k: {"episodes": len(v), "energy_ratio_p50": float(np.median([a for a, _ in v])),
            "peak_db_spl_p50": float(np.median([b for _, b in v])),
            "peak_db_spl_max": float(max(b for _, b in v))} for k, v in by_mat.items()}
    out["audio_energy_by_material"] = dict(sorted(
        by_mat_summary.items(), key=lambda kv: -kv[1]["energy_ratio_p50"]))
    # the rooms' reverberation: each variant once (its furnished RT60 per band)
    rt = _rt60_by_variant(rows)
    if rt:
        arr = np.array(list(rt.values()), float)  # (variants, 7)
        out["room_rt60_s"] = {
            "variants": len(rt),
            "by_band": {f"{fc:g}": _summary(arr[:, b])
                        for b, fc in enumerate((125, 250, 500, 1000, 2000, 4000, 8000))},
            "mid_500_1k": _summary(arr[:, 2:4].mean(1)),
            "by_variant_mid": {k: round(float(np.mean(v[2:4])), 3)
                               for k, v in sorted(rt.items())}}
    # where the episodes come from, against what was rehearsed
    skips = [(e, reason) for r in rows for e, reason in json.loads(r["skipped_events"])]
    skips += [(e, reason) for _, tried in dropped for e, reason in tried]
    out["spawn_sees_object"] = int(sum(r["spawn_sees_object"] for r in rows))
    out["episodes_on_a_fallback_event"] = int(sum(r["event_attempts"] > 1 for r in rows))
    falls = Counter(r["event_id"] for r in rows)
    # episodes that share a fall (the same event, another spawn): a build that has events to
    # spare gives each episode its own
    out["distinct_falls"] = len(falls)
    out["episodes_sharing_a_fall"] = int(sum(n for n in falls.values() if n > 1))
    out["skips_by_reason"] = _sorted(Counter(reason for _, reason in skips))
    rehearsed = Counter(events.values())
    used = Counter(r["zone_kind"] for r in rows)
    skipped_kind = Counter(events.get(e, "?") for e, _ in skips)
    tried_kind = used + skipped_kind
    n_ev = sum(rehearsed.values()) or 1
    n_ep = len(rows) or 1
    out["bias"] = {k: {"rehearsed_events": rehearsed[k],
                       "rehearsed_share": rehearsed[k] / n_ev,
                       "episode_share": used[k] / n_ep,
                       "ratio": (used[k] / n_ep) / (rehearsed[k] / n_ev) if rehearsed[k] else None,
                       "events_skipped": skipped_kind[k],
                       "skip_rate": skipped_kind[k] / tried_kind[k] if tried_kind[k] else None}
                   for k in sorted(set(rehearsed) | set(used))}
    out["goals"] = goals(rows)
    out["floors"] = floor_checks({r["room_variant"] for r in rows})
    out["goals"].update(floor_goals(out["floors"]))
    return out


def floor_checks(variants) -> dict[str, dict]:
    """The ISO tapping machine on the floors of these room variants, as this code renders a
    hit on them (:func:`fallgen.audio.floors.check_floor`): what a measurement can check of
    the floors' impact sound. The dataset keeps no copy of the materials, so these are the
    present ones (variants the present world lacks are left out)."""
    from dataclasses import asdict

    from fallgen.audio.floors import check_floor
    from fallgen.world.library import load_world

    world = load_world()
    known = {v.id: v for v in world.variants()}
    names = sorted({known[v].surfaces["floor"].name for v in variants if v in known})
    out = {}
    for n in names:
        c = check_floor(world.materials.surface(n), world.materials)
        out[n] = {**asdict(c), "bare_ok": c.bare_ok, "improvement_ok": c.improvement_ok,
                  "ok": c.ok}
    return out


def floor_goals(floors: dict[str, dict]) -> dict:
    """Two goals from :func:`floor_checks`: bare homogeneous floors against EN ISO 12354-2,
    and coverings' improvement against their measured ranges."""
    from fallgen.audio.floors import BARE_FLOOR_TOLERANCE_DB

    g = {}
    bare = {k: c for k, c in floors.items() if c["bare_ok"] is not None}
    if bare:
        g["floor_bare_vs_en12354"] = {
            "value": {k: c["bare_rating_db"] - c["bare_reference_db"] for k, c in bare.items()},
            "bound": f"within {BARE_FLOOR_TOLERANCE_DB:g} dB (L_n,w, tapping machine)",
            "ok": all(c["bare_ok"] for c in bare.values())}
    cover = {k: c for k, c in floors.items() if c["improvement_ok"] is not None}
    if cover:
        g["floor_covering_delta_lw"] = {
            "value": {k: c["improvement_db"] for k, c in cover.items()},
            "bound": ", ".join(f"{k} {c['improvement_range_db'][0]:g}-"
                               f"{c['improvement_range_db'][1]:g}" for k, c in cover.items()),
            "ok": all(c["improvement_ok"] for c in cover.values())}
    return g


def verdict(goal: dict) -> str:
    """How ``fallgen stats`` prints whether a goal is met: yes, NO, ``n/a (needs >= N
    episodes)`` for a goal this build is too small to judge, ? when it cannot be measured."""
    if goal["ok"] is None:
        return f"n/a (needs >= {goal['needs']} episodes)" if goal.get("needs") else "?"
    return "yes" if goal["ok"] else "NO"


def goals(rows: list[dict]) -> dict:
    """Each of :data:`GOALS` on these episodes: the measured value, the bound, and whether it
    holds (``None``: not measurable here, e.g. a dataset without the column; or, with
    ``needs``, a goal about the distribution judged only on :data:`MIN_EPISODES` episodes)."""
    g = _goals(rows)
    for name, n in MIN_EPISODES.items():
        if name in g and g[name].get("n", len(rows)) < n:
            g[name] = {**g[name], "ok": None, "needs": n}
    return g


def _hard_median(rows: list[dict], ratio_known: bool) -> dict:
    """The median energy ratio of the hard impacts (:data:`HARD_MATERIALS` onto them), over
    ``n`` of them; unknown (None) on a dataset without the ratio (``ratio_known`` False) or
    the first impact's surface."""
    lo, hi = GOALS["energy_ratio_median_hard"]
    bound = f"{lo:g}..{hi:g} (hard objects onto hard surfaces)"
    if not ratio_known or any("first_impact_surface" not in r for r in rows):
        return {"value": None, "bound": bound, "ok": None}
    hard = [r["audio_energy_ratio"] for r in rows if r["audio_material"] in HARD_MATERIALS
            and r["first_impact_surface"] in HARD_MATERIALS]
    if not hard:
        return {"value": None, "n": 0, "bound": bound, "ok": None}
    med = float(np.median(hard))
    return {"value": med, "n": len(hard), "bound": bound, "ok": lo <= med <= hi}


def _goals(rows: list[dict]) -> dict:
    g: dict[str, dict] = {}
    ratio = np.array([r.get("audio_energy_ratio", np.nan) for r in rows], float)
    ratio_known = bool(len(ratio)) and bool(np.isfinite(ratio).all())
    ceiling = GOALS["energy_ratio_ceiling"]
    if ratio_known:
        above = int((ratio > ceiling).sum())
        g["energy_ratio_above_ceiling"] = {"value": above, "bound": f"0 above {ceiling:g}",
                                           "ok": above == 0}
    else:
        g["energy_ratio_above_ceiling"] = {"value": None, "bound": f"0 above {ceiling:g}",
                                           "ok": None}
    g["energy_ratio_median_hard"] = _hard_median(rows, ratio_known)
    peak = np.array([r["audio_peak_db_spl"] for r in rows], float)
    if len(peak):
        lo, hi = GOALS["peak_db_spl"]
        out_of = int(((peak < lo) | (peak > hi)).sum())
        g["peak_db_spl_range"] = {"value": [float(peak.min()), float(peak.max())],
                                  "outside": out_of, "bound": f"{lo:g}..{hi:g}",
                                  "ok": out_of == 0}
        lo, hi = GOALS["peak_db_spl_p5_p95"]
        p5, p95 = (float(np.percentile(peak, q)) for q in (5, 95))
        g["peak_db_spl_p5_p95"] = {"value": [p5, p95], "bound": f"about {lo:g}..{hi:g} (5 dB)",
                                   "ok": lo - 5 <= p5 and p95 <= hi + 5}
        floor = [r["audio_peak_db_spl"] for r in rows if r["zone_kind"] == "floor"]
        if floor:
            f50 = float(np.median(floor))
            by = {k: float(np.median([r["audio_peak_db_spl"] for r in rows
                                      if r["zone_kind"] == k]))
                  for k in sorted({r["zone_kind"] for r in rows})}
            worst = max(by, key=lambda k: abs(by[k] - f50))
            lim = GOALS["zone_median_vs_floor_db"]
            g["zone_median_vs_floor"] = {"value": {k: round(v - f50, 1) for k, v in by.items()},
                                         "worst": worst, "bound": f"within {lim:g} dB",
                                         "ok": abs(by[worst] - f50) <= lim}
    fall = np.array([r.get("fall_height_m", np.nan) for r in rows], float)
    lim = GOALS["min_fall_m"]
    if len(fall) and np.isfinite(fall).all():
        short = int((fall < lim - 1e-9).sum())
        g["fall_height"] = {"value": float(fall.min()), "short": short,
                            "bound": f"every fall >= {lim:g} m", "ok": short == 0}
    else:
        g["fall_height"] = {"value": None, "bound": f"every fall >= {lim:g} m", "ok": None}
    rt = _rt60_by_variant(rows)
    lo, hi = GOALS["rt60_mid_s"]
    if rt:  # the rays traced for the variant, else the model widened by their ratio to it
        g["rt60_mid"] = rt60_goal({k: list(v[2:4]) for k, v in rt.items()})
    else:
        g["rt60_mid"] = {"value": None, "bound": f"{lo:g}..{hi:g} s", "ok": None}
    mats = Counter(r["audio_material"] for r in rows)
    if rows:
        share = min(mats.values()) / len(rows)
        lim = GOALS["material_min_share"]
        g["audio_materials"] = {"value": len(mats), "min_share": share,
                                "bound": f"{AUDIO_MATERIALS}, each >= {lim:.0%}",
                                "ok": len(mats) >= AUDIO_MATERIALS and share >= lim}
    return g


__all__ = ["stats", "goals", "verdict", "GOALS", "MIN_EPISODES", "floor_checks",
           "floor_goals"]
