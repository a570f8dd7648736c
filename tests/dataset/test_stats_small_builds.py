"""fallgen stats on builds too small for the goals about the episodes' distribution (a smoke
or demo build): those goals read "n/a (needs >= N episodes)", not NO; from N episodes on they
are judged."""

from __future__ import annotations

from fallgen.dataset.stats import MIN_EPISODES, goals, verdict


def _rows(n, materials=4):
    return [{"audio_energy_ratio": 1e-6, "audio_peak_db_spl": 60.0 + (i % 9),
             "fall_height_m": 0.5, "zone_kind": ("floor", "shelf")[i % 2],
             "audio_material": ("metal", *(f"m{k}" for k in range(1, materials)))[i % materials],
             "first_impact_surface": "stone", "room_variant": "v0",
             "room_rt60_s": [0.6] * 7} for i in range(n)]


def test_distribution_goals_wait_for_enough_episodes():
    small = goals(_rows(24))
    for name, n in MIN_EPISODES.items():
        assert small[name]["ok"] is None and small[name]["needs"] == n
        assert verdict(small[name]) == f"n/a (needs >= {n} episodes)"
    # the energy median waits for 20 hard impacts (6 of these 24 falls are): from 20 on it
    # is judged, and this one misses its bound
    assert small["energy_ratio_median_hard"]["n"] == 6
    hard = goals(_rows(80))["energy_ratio_median_hard"]
    assert hard["n"] == 20 and hard["ok"] is False and verdict(hard) == "NO"
    # goals every episode must meet are judged on any build
    assert small["fall_height"]["ok"] is True and verdict(small["fall_height"]) == "yes"


def test_from_enough_episodes_on_the_same_goals_are_judged():
    n = max(MIN_EPISODES.values())
    big = goals(_rows(n))
    assert big["audio_materials"]["ok"] is False  # 4 of 14 materials: a real miss now
    assert verdict(big["audio_materials"]) == "NO" and "needs" not in big["audio_materials"]
    assert big["peak_db_spl_p5_p95"]["ok"] is True
    assert verdict({"ok": None}) == "?"
