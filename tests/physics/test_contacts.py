"""Contact events from MuJoCo against analytic references: free fall, momentum, slip, roll."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

from fallgen.physics.contacts import ContactRecorder
from fallgen.world.scene import PlacedObject, build_scene

G = 9.81


def _floor_spot(world):
    """The centre of study_loft-l1-m1's largest floor zone at least 0.5 m from its rug (the
    tests slide and roll objects on the bare floor)."""
    v = world.variant("study_loft-l1-m1")
    rugs = [p.box for it in v.furniture if it.floor_covering for p in it.parts]

    def clear(z):
        c = np.array([[*z.volume.center[:2], 0.01]])
        return not any(r.contains(c, tol=0.5)[0] for r in rugs)

    z = max((z for z in v.zones if z.kind == "floor" and clear(z)),
            key=lambda z: z.volume.half[0] * z.volume.half[1])
    return v, z.volume.center[:2]


def _run(world, cat, z0, *, qvel=None, quat=(1, 0, 0, 0), steps=1200):
    v, (x, y) = _floor_spot(world)
    lib = world.categories
    var = lib[cat].variants[0]
    inst = lib.instance(cat, var.name, sorted(var.materials)[0])
    scene = build_scene(v, world.materials, [PlacedObject("t", inst, (x, y, z0), quat)])
    m, d = scene.model, scene.data()
    if qvel is not None:
        d.qvel[:6] = qvel
    mujoco.mj_forward(m, d)
    rec = ContactRecorder(m, scene.object_body["t"], scene.geom_owner, scene.geom_material)
    vz = []
    for _ in range(steps):
        rec.step(d)
        vz.append(d.qvel[2])
    return inst, rec.finish(), np.array(vz), m.opt.timestep


@pytest.mark.parametrize("cat", ["cup", "key", "bowl"])
def test_first_impact_matches_free_fall_and_momentum(world, cat):
    z0 = 1.2
    inst, events, vz, dt = _run(world, cat, z0)
    lowest = (inst.geometry.vertices * inst.scale).min(axis=0)[2]  # body frame, upright
    h = z0 + lowest
    t_ff = math.sqrt(2 * h / G)
    first = events[0]
    assert first.kind == "impact" and first.other == "floor"
    assert abs(first.time_s - t_ff) <= 2 * dt
    assert first.normal_speed_mps == pytest.approx(G * t_ff, rel=0.02)
    # (within 1 degree: the collision hull is coarse, 32 vertices, so its base is a polygon)
    assert first.normal == pytest.approx((0.0, 0.0, 1.0), abs=0.02)
    assert first.material_other == world.variant("study_loft-l1-m1").surfaces["floor"].impact_material
    # The recorded impulse is that of the compression phase: m v for a square hit on the floor,
    # whether the object then bounces or not (the whole contact delivers m v (1 + e)).
    assert first.impulse_ns == pytest.approx(inst.mass_kg * first.normal_speed_mps, rel=0.05)
    k0 = int(round(first.time_s / dt))
    k_end = next(k for k in range(k0, len(vz)) if vz[k] >= 0)  # first step moving up
    total = inst.mass_kg * (vz[k_end] - vz[k0 - 1])
    assert total >= first.impulse_ns * 0.95
    rebound = vz[k_end + 2] / first.normal_speed_mps if k_end + 2 < len(vz) else 0.0
    assert rebound < 0.9  # no energy gained


def test_resting_contact_is_not_an_impact(world):
    # (A bowl: a mug dropped upright may wobble on its rim like Euler's disk for ~3 s, making
    # real, late, small impacts.)
    inst, events, vz, dt = _run(world, "bowl", 0.3, steps=2500)
    impacts = [e for e in events if e.kind == "impact"]
    assert impacts and all(e.normal_speed_mps >= 0.05 for e in impacts)
    assert impacts[-1].time_s < 1.0  # nothing after it has settled (t up to 5 s)
    assert abs(vz[-1]) < 1e-3


def test_sliding_book_scrapes(world):
    # A book slid across the floor at 1.5 m/s: scrapes whose slip speed falls to zero by about
    # v / (mu g). MuJoCo's soft convex friction makes a sliding body hop and rock between its
    # edges (re-contacts at up to ~0.35 m/s a few ms apart); those are part of the scrape, not
    # impacts: none but the initial touch-down (the book starts 0.1 mm above the floor).
    inst, events, vz, dt = _run(world, "book", 0.0151, qvel=[1.5, 0, 0, 0, 0, 0], steps=600)
    assert [e for e in events if e.kind == "impact" and e.time_s > 0.05] == []
    scrapes = [e for e in events if e.kind == "scrape"]
    assert len(scrapes) >= 5
    assert 0.5 < scrapes[0].tangential_speed_mps <= 1.5
    assert scrapes[-1].tangential_speed_mps < 0.3 * scrapes[0].tangential_speed_mps
    mu = 0.5  # floor concrete_painted vs paper: MuJoCo takes the larger sliding friction
    assert scrapes[-1].time_s < 1.5 * 1.5 / (mu * G)
    assert all(e.other == "floor" and e.material_object == "paper" for e in scrapes)


def test_rolling_cylinder_rolls(world):
    # An AA battery lying on its side (axis along y), rolling along x without slipping:
    # v = w r; qvel's angular part is in the body frame, where the axis is z.
    r = 0.0072
    q = (math.cos(math.pi / 4), math.sin(math.pi / 4), 0.0, 0.0)  # axis along y
    inst, events, vz, dt = _run(world, "flashlight_battery", r + 0.0005, quat=q,
                                qvel=[0.5, 0, 0, 0, 0, -0.5 / r], steps=500)
    kinds = [e.kind for e in events]
    assert kinds.count("roll") >= 5
    assert kinds.count("roll") > kinds.count("scrape")
    rolls = [e for e in events if e.kind == "roll"]
    # The contact stays on the floor in the world but moves around the battery's surface.
    assert all(abs(e.point_world[2]) < 2e-3 for e in rolls)
    po = np.array([e.point_object for e in rolls])
    assert np.ptp(po[:, 0]) + np.ptp(po[:, 1]) > r  # body frame: the axis is z


def test_bounces_are_impacts_with_the_restitution(world):
    # A golf ball dropped from 1 m bounces several times, each bounce an impact at e times the
    # previous speed (e ~0.8: the ball is far softer than any floor, so it sets the bounce), at
    # the ballistic interval 2 e v / g (plus the few steps of contact). None is mistaken for a
    # sliding hop, and a bounce is not a scrape.
    inst, events, vz, dt = _run(world, "golf_ball", 1.0, steps=2000)
    imp = [e for e in events if e.kind == "impact"]
    assert len(imp) >= 4
    for a, b in zip(imp[:3], imp[1:4]):
        e = b.normal_speed_mps / a.normal_speed_mps
        assert 0.65 < e < 0.9, (a, b)
        assert b.time_s - a.time_s == pytest.approx(2 * b.normal_speed_mps / G, abs=6 * dt)
    assert [e for e in events if e.kind == "scrape" and e.time_s < imp[3].time_s] == []
