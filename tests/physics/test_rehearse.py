"""The rehearsal phase: kept events settle in their zone, replays are bit-identical (also in a
fresh process), and output does not depend on worker count or room order."""

from __future__ import annotations

import dataclasses
import json
import math
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

from fallgen.config import BuildConfig, RehearseConfig
from fallgen.physics.drop import replay
from fallgen.physics.settle import SettleCriteria
from fallgen.errors import InputError
from fallgen.physics.rehearse import fingerprint, read_events, rehearse, rehearse_variant

ROOMS = ["kitchen_galley-l1-m1", "study_office-l2-m2"]


def _cfg(tmp_path: Path, **kw) -> BuildConfig:
    r = RehearseConfig(rooms=",".join(ROOMS), zones="z0[0-3]", events_per_zone=1,
                       max_trials_per_zone=3,
                       settle=SettleCriteria(timeout_s=4.0))
    return BuildConfig(2022, tmp_path, dataclasses.replace(r, **kw), tmp_path / "cfg.toml")


@pytest.fixture(scope="module")
def events_and_stats(world, tmp_path_factory):
    cfg = _cfg(tmp_path_factory.mktemp("r"))
    return rehearse_variant(world, ROOMS[0], cfg)


def test_kept_events_settle_in_their_zone(world, events_and_stats):
    events, stats = events_and_stats
    assert events, stats.as_dict()
    assert stats.trials == sum(stats.reasons.values())
    for e in events:
        v = world.variant(e.room_variant)
        zone = v.zone(e.zone)
        com = np.array(e.settle_com)
        assert np.isfinite(com).all() and np.isfinite(e.settle_quat).all()
        assert zone.volume.contains(com[None, :])[0], e.event_id
        assert e.contacts and e.contacts[0].kind == "impact"
        assert all(np.isfinite(c.impulse_ns) for c in e.contacts)
        assert e.mass_kg == pytest.approx(world.categories.instance(
            e.target.category, e.target.variant, e.target.material, e.target.scale).mass_kg)


def test_replay_is_bit_identical(world, events_and_stats):
    events, _ = events_and_stats
    e = events[0]
    r = replay(world, e)
    assert tuple(r.settle_pos) == e.settle_pos
    assert tuple(r.settle_quat) == e.settle_quat
    assert r.contacts == e.contacts


def test_sweep_bounds_the_fall_and_a_clear_agent_changes_nothing(world, events_and_stats):
    """The recorded sweep holds the start and resting positions; an agent standing clear of it
    (pipeline.episode.clear_of_fall) leaves the replay bit-identical to the rehearsal, which is
    why generate reuses the rehearsal's contacts then; an agent on the fall's path is not
    clear."""
    from fallgen.nav.agent import AgentSpec, Pose
    from fallgen.physics.drop import instance_of
    from fallgen.pipeline.episode import clear_of_fall
    from fallgen.world.scene import AgentBody

    events, _ = events_and_stats
    spec = AgentSpec()
    tried = 0
    for e in events:
        x0, y0, x1, y1 = e.sweep_xy
        for p in (e.start_pos, e.settle_pos):
            assert x0 <= p[0] <= x1 and y0 <= p[1] <= y1
        target = instance_of(world, e.target)
        lx, ly, _ = world.variant(e.room_variant).size_m
        on_path = Pose(e.settle_pos[0], e.settle_pos[1], 0)
        assert not clear_of_fall(e, target, on_path, spec)
        assert not clear_of_fall(dataclasses.replace(e, sweep_xy=None), target,
                                 Pose(0.3, 0.3, 0), spec)  # unknown sweep: replay
        for x, y in ((0.35, 0.35), (lx - 0.35, ly - 0.35), (0.35, ly - 0.35)):
            pose = Pose(x, y, 3)
            if not clear_of_fall(e, target, pose, spec):
                continue
            tried += 1
            r = replay(world, e, agent=AgentBody(x, y, pose.yaw_rad, spec.radius_m,
                                                 spec.height_m))
            assert tuple(r.settle_pos) == e.settle_pos and r.contacts == e.contacts
    assert tried >= 2


def test_replay_in_a_fresh_process(world, events_and_stats, tmp_path):
    from fallgen.physics.rehearse import write_variant

    events, stats = events_and_stats
    path = tmp_path / "ev.parquet"
    write_variant(path, events, stats)
    code = textwrap.dedent(f"""
        import json
        from fallgen.world.library import load_world
        from fallgen.physics.drop import replay
        from fallgen.physics.rehearse import read_events
        w = load_world({str(world.root)!r})
        out = []
        for e in read_events({str(path)!r}):
            r = replay(w, e)
            out.append([list(map(float.hex, r.settle_pos)), list(map(float.hex, r.settle_quat)),
                        [float.hex(c.impulse_ns) for c in r.contacts], len(r.contacts)])
        print(json.dumps(out))
    """)
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True)
    got = json.loads(res.stdout.strip().splitlines()[-1])
    for e, (pos, quat, imp, n) in zip(read_events(path), got):
        assert pos == [float.hex(x) for x in e.settle_pos]
        assert quat == [float.hex(x) for x in e.settle_quat]
        assert n == len(e.contacts)
        assert imp == [float.hex(c.impulse_ns) for c in e.contacts]


def test_same_bytes_whatever_workers_and_order(world, tmp_path):
    a, b, c = tmp_path / "a", tmp_path / "b", tmp_path / "c"
    cfg = _cfg(tmp_path, zones="z0[0-1]", max_trials_per_zone=2)
    rehearse(world, cfg, ROOMS, out=a, workers=1)
    rehearse(world, cfg, ROOMS, out=b, workers=2)
    rehearse(world, cfg, ROOMS[::-1], out=c, workers=1)
    for vid in ROOMS:
        name = f"{vid}.parquet"
        assert (a / name).read_bytes() == (b / name).read_bytes() == (c / name).read_bytes()
    # A rerun skips finished variants (their files are untouched).
    mtime = (a / f"{ROOMS[0]}.parquet").stat().st_mtime_ns
    rehearse(world, cfg, ROOMS, out=a, workers=1)
    assert (a / f"{ROOMS[0]}.parquet").stat().st_mtime_ns == mtime
    # ... made under the same config only: another one is refused, naming the file
    other = dataclasses.replace(cfg, rehearse=dataclasses.replace(cfg.rehearse, min_fall_m=0.4))
    with pytest.raises(InputError, match=r"stats\.json: fingerprint: rehearsed under another"):
        rehearse(world, other, ROOMS, out=a, workers=1)
    with pytest.raises(InputError, match="fingerprint"):
        rehearse(world, dataclasses.replace(cfg, root_seed=7), ROOMS, out=a, workers=1)
    assert (a / f"{ROOMS[0]}.parquet").stat().st_mtime_ns == mtime
    # the rooms picked are not part of it
    rehearse(world, dataclasses.replace(cfg, rehearse=dataclasses.replace(
        cfg.rehearse, rooms=ROOMS[0])), ROOMS[:1], out=a, workers=1)
    rehearse(world, other, ROOMS, out=a, workers=1, force=True)  # --force redoes them
    assert json.loads((a / f"{ROOMS[0]}.stats.json").read_text())["fingerprint"] == \
        fingerprint(world, other)


def test_spinning_fork_does_not_diverge(world):
    """Regression: this fork, spinning at ~7 rad/s when it hits the floor, went NaN with the
    Euler integrator; implicitfast keeps it stable."""
    from fallgen.physics.drop import run_trial

    v = world.variant("kitchen_island-l1-m1")
    cfg = RehearseConfig(drop_height_m=(1.5, 2.8), events_per_zone=8, max_trials_per_zone=60)
    out = run_trial(world, v, v.zone("z00"), 9, cfg, 2022)
    assert out.category == "fork"
    assert out.reason != "unstable"


def test_a_trial_given_its_zones_fits_is_the_trial_made_without(world):
    """The categories that fit a zone, found once for its trials (as the rehearsal does),
    make the same trials as found by each trial: the same draws, outcome and event."""
    from fallgen.physics.drop import run_trial, zone_fits

    v = world.variant("kitchen_island-l1-m1")
    cfg = RehearseConfig(drop_height_m=(1.5, 2.8), events_per_zone=8, max_trials_per_zone=60)
    for zone in v.zones[:3]:
        fits = zone_fits(world, zone)
        assert fits.targets and all(fits.distractors[c] for c in fits.targets)
        for trial in range(2):
            assert run_trial(world, v, zone, trial, cfg, 2022, fits) == \
                run_trial(world, v, zone, trial, cfg, 2022)


def test_a_trial_below_its_zone_for_good_is_stopped(world):
    """A trial is stopped early only when the object cannot climb back to the zone: resting
    below it, yes; moving up fast enough, or spinning with enough energy, no."""
    import mujoco

    from fallgen.physics.drop import PHYSICS, _below_for_good
    from fallgen.world.scene import PlacedObject, build_scene

    inst = world.categories.instance("cup", "mug", "ceramic")
    scene = build_scene(world.variant(ROOMS[0]), world.materials,
                        [PlacedObject("target", inst, (2.0, 1.0, 0.3))], settings=PHYSICS)
    m, b = scene.model, scene.object_body["target"]
    d = scene.data()
    mujoco.mj_forward(m, d)
    vadr = m.jnt_dofadr[m.body_jntadr[b]]
    zone_floor = 0.8
    give_up = _below_for_good(m, b, zone_floor)
    assert give_up(d)
    assert not _below_for_good(m, b, float(d.xipos[b, 2]))(d)  # already at the zone's floor
    d.qvel[vadr + 2] = 4.0  # rises 0.82 m on its own
    assert not give_up(d)
    d.qvel[vadr + 2] = 2.0  # 0.2 m (x 1.5 margin): still short
    assert give_up(d)
    d.qvel[vadr:vadr + 6] = 0.0
    rise = zone_floor - float(d.xipos[b, 2])
    w = np.sqrt(2 * m.body_mass[b] * 9.81 * rise / m.body_inertia[b].sum())
    d.qvel[vadr + 3:vadr + 6] = w  # enough spin to lift it there
    assert not give_up(d)


def test_a_start_overlap_is_rejected_without_simulating(world):
    """A target placed into a fixed object is rejected as it starts: no step is simulated
    (the trial's verdict cannot change), and nothing is recorded."""
    from fallgen.physics.drop import _simulate
    from fallgen.world.scene import PlacedObject

    cup = world.categories.instance("cup", "mug", "ceramic")
    objs = [PlacedObject("target", cup, (2.0, 1.0, 0.3)),
            PlacedObject("o0", cup, (2.0, 1.0, 0.31), free=False)]
    res, contacts, com, mass, overlap, _ = _simulate(
        world, world.variant(ROOMS[0]), objs, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0),
        SettleCriteria())
    assert overlap
    assert res.steps == 0 and not res.settled and contacts == []
    assert com[2] == pytest.approx(0.3, abs=0.05)
    assert mass == pytest.approx(cup.mass_kg, rel=1e-9)
    # without the fixed box the same start is simulated until it rests
    res, contacts, _, _, overlap, _ = _simulate(world, world.variant(ROOMS[0]), objs[:1],
                                                (0.0, 0.0, 0.0), (0.0, 0.0, 0.0),
                                                SettleCriteria())
    assert not overlap and res.steps > 0 and res.settled and contacts


def test_covered_zones_are_reached_by_real_falls(world, tmp_path):
    """Every kept event falls at least min_fall_m before its first impact, also into a shelf
    between two boards (0.46 m: small objects start inside, higher), under a sofa (9 cm:
    landing before it, sliding under) and under a dining table (room enough below its top,
    but an object gets there off the table, not from beneath it: every start lies beside the
    table, above its top); a stricter minimum leaves no shorter fall."""
    from fallgen.physics.drop import COVER_CLEARANCE_M, fall_height_m

    cases = [("kitchen_galley-l1-m1", ("shelf", "counter_top")),
             ("study_lounge-l1-m1", ("under_furniture",)),
             ("kitchen_dining-l1-m1", ("under_furniture",))]
    started_beside = 0
    for vid, kinds in cases:
        v = world.variant(vid)
        events = []
        for kind in kinds:  # the first zone of each kind
            zone = next(z for z in v.zones if z.kind == kind)
            r = RehearseConfig(rooms=vid, zones=zone.id, events_per_zone=2,
                               max_trials_per_zone=40, min_fall_m=0.3,
                               settle=SettleCriteria(timeout_s=4.0))
            got, stats = rehearse_variant(world, vid, BuildConfig(2022, tmp_path, r,
                                                                  tmp_path / "cfg.toml"))
            assert got, (vid, kind, stats.as_dict())
            events += got
        for e in events:
            assert fall_height_m(e.contacts, e.start_linvel[2]) >= 0.3, e.event_id
            zone = v.zone(e.zone)
            started_beside += not zone.drop.contains(np.array([e.start_pos]), 1e-6)[0]
            if zone.kind == "under_furniture":
                assert not zone.drop.contains(np.array([e.start_pos]), 1e-6)[0], e.event_id
                assert e.start_pos[2] >= zone.drop.zmax + COVER_CLEARANCE_M, e.event_id
    assert started_beside > 0  # some fell from outside their zone's cavity


def test_a_trial_given_up_before_its_fall_settles_no_distractors(world, monkeypatch):
    """A shelf trial with no start beside the zone (does_not_fit) draws its distractors (the
    draws of later trials do not depend on it) but compiles no scene to settle them; a trial
    that falls settles them first, then drops the target (two scenes)."""
    from fallgen.physics import drop

    cfg = BuildConfig(2022, Path("."), RehearseConfig(), Path("cfg.toml"))
    v = world.variant("kitchen_dining-l1-m1")
    zone = v.zone("z13")
    assert zone.kind == "shelf" and zone.distractors > 0
    compiled = []
    build = drop.build_scene
    monkeypatch.setattr(drop, "build_scene", lambda *a, **k: compiled.append(1) or build(*a, **k))
    out = drop.run_trial(world, v, zone, 1, cfg.rehearse, cfg.root_seed)
    assert out.reason == "does_not_fit" and out.category and compiled == []
    for trial in range(2, 12):
        compiled.clear()
        out = drop.run_trial(world, v, zone, trial, cfg.rehearse, cfg.root_seed)
        if out.reason not in ("does_not_fit", "start_overlap"):
            assert len(compiled) == 2, (trial, out.reason)
            return
    raise AssertionError("no trial of the zone fell")


def test_a_fall_under_furniture_lands_before_the_opening_moving_toward_it(world):
    """The throw under a sofa, a coffee table and a dining table: its ballistic flight (no
    drag) comes down to the floor, at the object's radius, 2-30 cm beyond the radius from the
    cover's edge, moving straight at the region's centre at 1.5-3 m/s, from a start above the
    cover's underside by the clearance, outside its footprint."""
    from fallgen.physics.drop import COVER_CLEARANCE_M, GRAVITY, _landing

    rng = np.random.default_rng(7)
    for vid, zid in [("study_lounge-l1-m1", "z04"), ("study_lounge-l1-m1", "z05"),
                     ("kitchen_dining-l1-m1", "z16")]:
        zone = world.variant(vid).zone(zid)
        d = zone.drop
        c, s = math.cos(d.yaw), math.sin(d.yaw)
        found = 0
        for _ in range(20):
            r = float(rng.uniform(0.02, 0.04))
            z_lo = max(zone.volume.zmin + 0.3 + r, d.zmax + COVER_CLEARANCE_M + r)
            start = _landing(rng, world.variant(vid), zone, r, z_lo, z_lo + 0.3)
            if start is None:  # no clear side (a table's chairs)
                continue
            found += 1
            x, y, z, (vx, vy) = start
            assert z_lo <= z <= z_lo + 0.3
            t = math.sqrt(2 * (z - zone.volume.zmin - r) / GRAVITY)
            lx, ly = x + vx * t - d.center[0], y + vy * t - d.center[1]
            px, py = c * lx + s * ly, -s * lx + c * ly  # the landing, in the region's frame
            # its distance beyond the footprint's edge along the way in
            n = math.hypot(px, py)
            edge = min(d.half[0] / max(abs(px) / n, 1e-9), d.half[1] / max(abs(py) / n, 1e-9))
            assert r + 0.02 - 1e-9 <= n - edge <= r + 0.30 + 1e-9
            assert 1.5 - 1e-9 <= math.hypot(vx, vy) <= 3.0 + 1e-9
            assert (vx * lx + vy * ly) / (math.hypot(vx, vy) * math.hypot(lx, ly)) < -0.999999
            assert not d.contains(np.array([[x, y, z]]), 1e-6)[0]
        assert found >= 10, (vid, zid, found)


def test_falls_reach_under_a_sofa_and_a_coffee_table(world):
    """Of 40 seeded trials, more than 6 come to rest under a sofa (9 cm of clearance) and
    under a coffee table (36 cm, 36 cm deep); thrown from above the cover at its edge, 1-3
    of 40 did."""
    from fallgen.physics.drop import run_trial

    v = world.variant("study_lounge-l1-m1")
    for zid in ("z04", "z05"):
        kept = sum(run_trial(world, v, v.zone(zid), t, RehearseConfig(), 2022).reason == "kept"
                   for t in range(40))
        assert kept > 6, (zid, kept)
