"""Bounce: every material's contact parameters reproduce its coefficient of restitution, no pair
of materials gains energy, the softer body of a pair sets the bounce, and a golf ball dropped in
a real room bounces about as high as a golf ball does."""

from __future__ import annotations

import itertools
import math

import mujoco
import numpy as np
import pytest

from fallgen.physics.calibrate import FIT_SPEEDS_MPS, bounce, fit_solref
from fallgen.world.scene import PlacedObject, build_scene


def _used(world):
    """Materials that meet in contacts: every object material and every surface's."""
    return sorted(world.materials.objects)


def test_every_material_bounces_with_its_restitution(world):
    for name in _used(world):
        m = world.materials.object(name)
        e = bounce(m.solref, m.solref, 2.5).restitution
        assert abs(e - m.restitution) <= 0.05, f"{name}: e = {e:.3f}, wanted {m.restitution}"


def test_no_pair_gains_energy_or_tunnels(world):
    mats = [world.materials.object(n) for n in _used(world)]
    for a, b in itertools.combinations_with_replacement(mats, 2):
        for v in FIT_SPEEDS_MPS:
            r = bounce(a.solref, b.solref, v, mix=(a.solmix, b.solmix))
            where = f"{a.name} on {b.name} at {v} m/s"
            assert r.restitution < 0.9, f"{where}: e = {r.restitution:.3f}"
            # A 10 cm slab is never crossed; a 2 cm board (the thinnest) is not either.
            assert r.penetration_m < 0.035, f"{where}: {1000 * r.penetration_m:.1f} mm"


@pytest.mark.parametrize("ball,surface,lo,hi", [
    ("plastic_hard/golf_ball", "wood_hard", 0.7, 0.9),   # the ball is far softer: it decides
    ("plastic_hard/golf_ball", "stone", 0.7, 0.9),
    ("metal", "wood_hard", 0.4, 0.65),                     # the wood is softer: wood-like bounce
    ("glass", "ceramic", 0.5, 0.75),                       # alike: in between
    ("metal", "fabric", 0.0, 0.15),                        # anything thuds on a carpet
    ("plastic_hard/golf_ball", "fabric", 0.0, 0.15),
])
def test_softer_body_sets_the_bounce(world, ball, surface, lo, hi):
    a, b = world.materials.object(ball), world.materials.object(surface)
    e = bounce(a.solref, b.solref, 2.5, mix=(a.solmix, b.solmix)).restitution
    assert lo <= e <= hi, f"{ball} on {surface}: e = {e:.3f}"


def test_fit_reproduces_the_wanted_restitution_and_refuses_the_impossible():
    for want in (0.1, 0.5, 0.78):
        f = fit_solref(want)
        assert abs(f.restitution[1] - want) <= 0.03
        assert max(f.restitution) < 0.95 and f.penetration_m <= 0.025
        # A fit is a real bounce: re-measure it independently.
        assert abs(bounce(f.solref, f.solref, 2.5).restitution - f.restitution[1]) < 1e-12
    with pytest.raises(ValueError):
        fit_solref(0.99)


#: A golf ball dropped on a rigid surface rebounds with e ~0.8 at low speed (Cross, "The bounce
#: of a ball", Am. J. Phys. 67, 1999)
GOLF_BALL_E = 0.8


def _check_rebound(peak_m: float, drop_m: float) -> None:
    """The rebound's restitution sqrt(h / H) is Cross's golf ball's within 0.05 (how close the
    contact fit holds any material's restitution: test_every_material_bounces...)."""
    assert abs(math.sqrt(peak_m / drop_m) - GOLF_BALL_E) <= 0.05, peak_m


def test_golf_ball_rebounds_in_a_room(world):
    """A golf ball dropped from 1 m onto a hardwood floor rises back to about e^2 = 0.64 m,
    e the restitution measured for golf balls."""
    v = next(v for r in world.rooms.values() for v in r.variants
             if v.surfaces["floor"].impact_material == "wood_hard")
    lib = world.categories
    ball = lib.instance("golf_ball", lib["golf_ball"].variants[0].name, "plastic_hard/golf_ball")
    zone = next(z for z in v.zones if z.kind == "floor" and z.open_above)
    r = float(ball.extents_m.max()) / 2
    start = (zone.volume.center[0], zone.volume.center[1], 1.0 + r)
    scene = build_scene(v, world.materials, [PlacedObject("target", ball, start, (1, 0, 0, 0))])
    m, d = scene.model, scene.data()
    adr = m.jnt_qposadr[m.body_jntadr[scene.object_body["target"]]]
    hit, peak = False, 0.0
    for _ in range(int(1.5 / m.opt.timestep)):
        mujoco.mj_step(m, d)
        h = float(d.qpos[adr + 2]) - r - zone.volume.zmin
        hit |= h < 0.005
        if hit:
            peak = max(peak, h)
    _check_rebound(peak, 1.0)
    assert np.isfinite(d.qpos).all()
    for wrong in (0.45, 0.8):  # what the old bounds let through at either end
        with pytest.raises(AssertionError):
            _check_rebound(wrong, 1.0)
