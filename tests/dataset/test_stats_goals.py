"""fallgen stats' physical goals, on hand-made rows: each goal is met or missed
exactly where its bound says."""

from __future__ import annotations

from fallgen.dataset.stats import AUDIO_MATERIALS, GOALS, goals

#: every other target is glass, the rest made-up materials (14 in all)
_MATERIALS = ["glass"] + [f"m{k}" for k in range(1, AUDIO_MATERIALS)]


def _rows(n=200, ratio=1e-3, peak=80.0, kinds=("floor", "shelf"), materials=AUDIO_MATERIALS,
          rt60=0.4, surface="stone"):
    return [{"audio_energy_ratio": ratio, "audio_peak_db_spl": peak + (i % 7),
             "fall_height_m": 0.3 + 0.01 * (i % 50),
             "zone_kind": kinds[i % len(kinds)],
             "audio_material": "glass" if i % 2 else _MATERIALS[(i // 2) % materials],
             "first_impact_surface": surface if i % 3 else "fabric/rug",
             "room_variant": f"v{i % 4}", "room_rt60_s": [0.8, 0.7, rt60, rt60, 0.5, 0.4, 0.3]}
            for i in range(n)]


def test_a_build_within_every_bound_meets_every_goal():
    g = goals(_rows())
    assert all(v["ok"] for v in g.values()), g


def test_each_goal_fails_on_its_own_violation():
    rows = _rows()
    rows[3]["audio_energy_ratio"] = GOALS["energy_ratio_ceiling"] * 1.1
    g = goals(rows)
    assert g["energy_ratio_above_ceiling"] == {**g["energy_ratio_above_ceiling"], "value": 1,
                                               "ok": False}
    assert g["energy_ratio_median_hard"]["ok"]
    assert not goals(_rows(ratio=0.02))["energy_ratio_median_hard"]["ok"]
    rows = _rows()
    rows[5]["audio_peak_db_spl"] = 20.0  # below a quiet home's noise floor
    assert goals(rows)["peak_db_spl_range"]["outside"] == 1
    loud = _rows(peak=115.0)
    assert not goals(loud)["peak_db_spl_p5_p95"]["ok"]
    shelf_loud = [dict(r, audio_peak_db_spl=r["audio_peak_db_spl"] + 20 * (r["zone_kind"] ==
                                                                             "shelf"))
                  for r in _rows()]
    z = goals(shelf_loud)["zone_median_vs_floor"]
    assert z["worst"] == "shelf" and not z["ok"]
    assert not goals(_rows(materials=12))["audio_materials"]["ok"]
    rows = _rows()
    for r in rows:  # one variant rings like an empty room
        if r["room_variant"] == "v2":
            r["room_rt60_s"] = [3.0] * 7
    g = goals(rows)["rt60_mid"]
    assert g["variants_outside"] == ["v2"] and not g["ok"]
    assert not goals(_rows(rt60=0.2))["rt60_mid"]["ok"]  # a studio, not a home
    rows = _rows()
    rows[7]["fall_height_m"] = 0.05  # barely a fall
    assert goals(rows)["fall_height"] == {**goals(rows)["fall_height"], "short": 1, "ok": False}


def test_a_dataset_without_the_energy_column_says_unknown():
    rows = [{k: v for k, v in r.items() if k != "audio_energy_ratio"} for r in _rows()]
    assert goals(rows)["energy_ratio_above_ceiling"]["ok"] is None
    assert goals(rows)["energy_ratio_median_hard"]["ok"] is None
    older = [{k: v for k, v in r.items() if k != "first_impact_surface"} for r in _rows()]
    assert goals(older)["energy_ratio_median_hard"] == {
        "value": None, "bound": goals(older)["energy_ratio_median_hard"]["bound"], "ok": None}


def test_the_energy_median_is_judged_on_hard_objects_falling_onto_hard_surfaces():
    """Soft landings and soft or light bodies radiate far less than measured hard impacts, for
    which alone a range is measured: the median is theirs, and only theirs."""
    rows = _rows(ratio=1e-3)
    for i, r in enumerate(rows):  # the falls onto the rug, and the made-up materials: quiet
        if r["first_impact_surface"] == "fabric/rug" or r["audio_material"] != "glass":
            r["audio_energy_ratio"] = 1e-7
    g = goals(rows)["energy_ratio_median_hard"]
    hard = [r for r in rows if r["audio_material"] == "glass"
            and r["first_impact_surface"] == "stone"]
    assert g["value"] == 1e-3 and g["n"] == len(hard) and g["ok"]
    # the same falls onto a gypsum board (a finish on stone) or an appliance are not hard ones
    for surface in ("stone/gypsum", "metal/appliance"):
        assert goals(_rows(surface=surface))["energy_ratio_median_hard"]["value"] is None
    # a hard material that radiates too little misses it, whatever the soft falls do
    quiet = [dict(r, audio_energy_ratio=3e-5) if r in hard else r for r in rows]
    assert goals(quiet)["energy_ratio_median_hard"]["ok"] is False
