"""The sound of a whole fall: both bodies ring, faster falls are louder, soft objects thud,
deterministic for the same generator."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from fallgen.audio import AUDIO_ENERGY_CEILING
from fallgen.audio.fall import AudioSettings, FallRenderer, _nbytes, is_panel
from fallgen.audio.impact import radiated_energy_j
from fallgen.audio.modes import ModalSettings
from fallgen.physics.drop import PHYSICS
from fallgen.physics.events import ObjectSpec, Placement
from fallgen.world.scene import PlacedObject, build_scene

FS = 44100


@pytest.fixture(scope="module")
def renderer(world, tmp_path_factory):
    s = AudioSettings(length_s=2.0, modal=ModalSettings(target_voxels=1500, n_modes=24),
                      cache_dir=tmp_path_factory.mktemp("modes"))
    return FallRenderer(world, s)


@pytest.fixture(scope="module")
def build_renderer(world, tmp_path_factory):
    """With the build's modal settings (the contact depends on the modes kept)."""
    return FallRenderer(world, AudioSettings(cache_dir=tmp_path_factory.mktemp("modes")))


def _rms(p):
    return float(np.sqrt(np.mean(p ** 2)))


def _first_impact(e):
    """The event with its first impact alone (the fall's other contacts left out)."""
    first = next(c for c in e.contacts if c.kind == "impact")
    return dataclasses.replace(e, contacts=(first,)), first


def _floor_reference_j(world, e, c) -> float:
    """The dry energy (J, as radiated_energy_j counts it) of the floor's sound for one impact
    by the floor model that is checked against building acoustics (fallgen.audio.floors: the
    ISO tapping machine rates within 1 dB of EN ISO 12354-2, carpets' and the rug's Delta L_w
    within their measured ranges): a rigid impactor of the impact's effective mass (its
    recorded compression impulse over its speed), in the target's material, on the
    variant's floor struck through what the impact met (its finish, or a rug on it), without
    the bodies' modes."""
    from fallgen.audio.floors import hit_pressure, surface_plate

    inst = world.categories.instance(e.target.category, e.target.variant, e.target.material,
                                     e.target.scale)
    floor = dataclasses.replace(world.variant(e.room_variant).surfaces["floor"],
                                impact_material=c.material_other)
    plate = surface_plate(floor, world.materials)
    radius = float(np.clip(0.25 * np.min(inst.extents_m), 0.001, 0.05))  # as fall.py takes it
    m_eff = min(c.impulse_ns / c.normal_speed_mps, inst.mass_kg)
    p, _, _, _ = hit_pressure(plate, inst.material, m_eff, radius, c.normal_speed_mps, FS)
    return radiated_energy_j(p, FS)


def _check_floor_hit(p_floor, ref_j, tol_db=2.0):
    """A fall's floor sound for one impact carries the floor model's energy within
    ``tol_db`` (the coupled contact lends part of the impact to the object's modes)."""
    got = radiated_energy_j(p_floor, FS)
    assert abs(10 * np.log10(got / ref_j)) <= tol_db, (got, ref_j)


def test_fall_sound_both_bodies_deterministic(world, renderer, drop_event):
    e = drop_event(world, "key", "house", "metal/brass", 1.0)
    assert any(c.kind == "impact" for c in e.contacts)
    parts = renderer.render_bodies(e, np.random.default_rng(1))
    assert set(parts) >= {"target", "floor"}
    total = renderer.render(e, np.random.default_rng(1))
    assert np.array_equal(total, renderer.render(e, np.random.default_rng(1)))
    assert np.allclose(total, np.sum(list(parts.values()), axis=0))
    assert total.shape == (2 * FS,)
    # absolute units: the floor's share of the first impact (a brass key dropped 1 m onto
    # study_loft's concrete) is the building-acoustics floor model's for that impact, within
    # 2 dB; and the key rings louder than the slab it hits (its modes, not only its click)
    one, c = _first_impact(e)
    first = renderer.render_bodies(one, np.random.default_rng(1))
    ref = _floor_reference_j(world, e, c)
    _check_floor_hit(first["floor"], ref)
    assert radiated_energy_j(first["target"], FS) > radiated_energy_j(first["floor"], FS)
    # the check rejects a floor 6 dB too loud or too quiet, and a normalised one (1 Pa peak)
    for wrong in (2 * first["floor"], first["floor"] / 2,
                  first["floor"] / np.abs(first["floor"]).max()):
        with pytest.raises(AssertionError):
            _check_floor_hit(wrong, ref)
    # silent before the first contact
    t0 = min(c.time_s for c in e.contacts)
    assert np.abs(total[: int(t0 * FS) - 2]).max() == 0.0


def test_higher_fall_is_louder(world, renderer, drop_event):
    events = [drop_event(world, "key", "house", "metal/brass", h) for h in (0.3, 1.5)]
    low, high = (renderer.render(e, np.random.default_rng(0)) for e in events)
    # first-impact speed ratio sqrt(1.5 / 0.3) = 2.2: the loudest moment is clearly louder
    assert np.abs(high).max() > 1.5 * np.abs(low).max()
    # and each first floor hit carries what the floor model gives its impact (2.4 and
    # 5.4 m/s: 8.5 dB apart by that model), within 2 dB
    refs = []
    for e in events:
        one, c = _first_impact(e)
        refs.append(_floor_reference_j(world, e, c))
        _check_floor_hit(renderer.render_bodies(one, np.random.default_rng(0))["floor"], refs[-1])
    assert refs[1] > 4 * refs[0]  # 6 dB at least


def johnson_contact_time(e1, nu1, e2, nu2, radius_m, mass_kg, speed_mps) -> float:
    """Johnson (Contact Mechanics, 1985, sec. 11.4): a Hertz impact of a body of mass m*
    whose contact has radius R* on a flat of the other material lasts
    t = 2.87 (m*^2 / (R* E*^2 v))^(1/5), 1/E* = (1 - nu1^2)/E1 + (1 - nu2^2)/E2."""
    e_star = 1.0 / ((1 - nu1 ** 2) / e1 + (1 - nu2 ** 2) / e2)
    return 2.87 * (mass_kg ** 2 / (radius_m * e_star ** 2 * speed_mps)) ** 0.2


def test_the_contact_is_the_hertz_contact_of_the_effective_mass(world, renderer, monkeypatch):
    """An impact whose recorded impulse is a third of m v (a knife struck at its tip: the
    floor meets an effective mass m* = J / v of a third of its mass) is the Hertz contact of
    m*: the contact spring lasts Johnson's t = 2.87 (m*^2 / (R* E*^2 v))^(1/5) with m*, within
    0.5 % (his 2.87 is 2.868 rounded), and so does the force on a slab when the bodies' modes
    are left out (the slab is rigid). The whole mass's Hertz time is (m / m*)^(2/5) = 1.55
    times longer, a spring (m* / m)^(4/5) = 0.42 times as stiff: rejected."""
    import fallgen.audio.fall as fall
    from fallgen.audio.coupling import coupled_impact
    from fallgen.physics.contacts import ContactEvent

    seen = []

    def rigid(m, v, tc, bodies):  # the modes left out: the contact alone
        seen.append((m, v, tc))
        return coupled_impact(m, v, tc, [(w, 0 * b) for w, b in bodies])

    monkeypatch.setattr(fall, "coupled_impact", rigid)
    mats = world.materials
    floor = mats.surface("concrete_bare")
    finish = mats.object(floor.impact_material)
    knife = world.categories.instance("knife", "table", "metal")
    target = renderer._object_body(knife, np.zeros(3), np.eye(3))
    patch = renderer._surface_body(finish, floor, np.zeros(3), np.eye(3))
    a = target.sounding
    v, m = 4.4, knife.mass_kg
    j = m * v / 3.0
    point = target.sounding.modes.points[int(np.argmin(target.sounding.modes.points[:, 0]))]
    c = ContactEvent(0.1, "impact", "floor", 0, 1, "metal", finish.name, (0, 0, 0),
                     tuple(map(float, point)), (0.0, 0.0, 1.0), v, j, 0.0, 0.004, j / 0.004)
    renderer._add_hits(c, target, patch, np.random.default_rng(0))
    (m_star, v_seen, tc), = seen
    assert m_star == pytest.approx(j / v, rel=1e-12) and v_seen == v
    ref = johnson_contact_time(a.contact_modulus_pa, a.poisson_ratio,
                               finish.contact_modulus_pa, finish.poisson_ratio,
                               a.contact_radius_m, m_star, v)
    whole = johnson_contact_time(a.contact_modulus_pa, a.poisson_ratio,
                                 finish.contact_modulus_pa, finish.poisson_ratio,
                                 a.contact_radius_m, m, v)
    (_, _, t_force), = patch.hits[0].force_pulses()
    for t in (tc, t_force):
        assert t == pytest.approx(ref, rel=0.005), (t, ref)
        assert t != pytest.approx(whole, rel=0.005)
    assert whole / ref == pytest.approx(3.0 ** 0.4, rel=1e-9)
    # the force is the impact's: its impulse (1 + e) m* v (the slab takes next to nothing
    # of the rebound: Zener's zeta ~1e-3)
    e = min(knife.material.restitution, finish.restitution)
    assert patch.hits[0].impulse_ns == pytest.approx(j * (1 + e), rel=0.005)


def test_a_bouncing_slender_objects_floor_hit_is_the_floor_models(world, renderer,
                                                                  drop_event):
    """Over-ear headphones dropped 1 m onto concrete strike it with their headband: its low
    modes (tens of Hz) throw the contact point off the floor and back, two contacts 45 Hertz
    times apart. The floor's sound is the floor model's for the impact (a rigid impactor of
    the effective mass, checked against EN ISO 12354-2 and the ISO tapping machine) within
    3 dB: two contacts that share the impulse radiate between all of one pulse's energy and
    the sum of their shares squared (0.5, -3 dB, for halves), as two separate hits do. The
    force spread over the time to the last parting (one 18 ms pulse, most of it flight) made
    the floor 25 dB quieter: the check rejects it."""
    import dataclasses as dc

    e = drop_event(world, "headphone", "over_ear", "plastic_hard", 1.0)
    one, c = _first_impact(e)
    assert c.other == "floor"
    _, others, _ = renderer._bodies(one, np.random.default_rng(0), None)
    floor = dict(others)["floor"]
    hit, = floor.hits
    pulses = hit.force_pulses()
    parting = hit.modal_state[2]
    assert len(pulses) >= 2 and parting > 10 * hit.duration_s  # it bounces
    ref = _floor_reference_j(world, e, c)
    _check_floor_hit(floor.render(renderer.s), ref, tol_db=3.0)
    spread = dc.replace(floor, hits=[dc.replace(hit, pulses=None, duration_s=parting)])
    for wrong in (spread.render(renderer.s), 2 * floor.render(renderer.s),
                  floor.render(renderer.s) / 2):
        with pytest.raises(AssertionError):
            _check_floor_hit(wrong, ref, tol_db=3.0)


def _t60(p):
    i = int(np.argmax(np.abs(p)))
    edc = np.cumsum((p[i:] ** 2)[::-1])[::-1]
    db = 10 * np.log10(edc / edc[0] + 1e-300)
    k = np.nonzero((db <= -5) & (db >= -35))[0]
    if len(k) < 2:
        return 0.0
    return -60 / np.polyfit(k / FS, db[k], 1)[0]


def test_soft_object_thuds_hard_object_rings(world, renderer, drop_event):
    def first_hit(e):  # the first impact alone
        first = next(c for c in e.contacts if c.kind == "impact")
        return dataclasses.replace(e, contacts=(first,))

    plush = renderer.render_bodies(first_hit(drop_event(world, "toy", "plush_ball", "fabric",
                                                         1.0)), np.random.default_rng(0))
    tile = renderer.render_bodies(first_hit(drop_event(world, "coaster", "tile", "ceramic",
                                                        1.0)), np.random.default_rng(0))
    assert _rms(plush["target"]) > 0  # not silence
    assert _t60(tile["target"]) > 0.05  # a ceramic tile rings
    assert _t60(plush["target"]) < 0.2 * _t60(tile["target"])  # a plush ball does not


def _centroid_hz(p):
    f = np.fft.rfftfreq(len(p), 1 / FS)
    power = np.abs(np.fft.rfft(p)) ** 2
    return float((f * power).sum() / power.sum())


def test_a_fall_onto_a_rug_is_a_dull_thud(world, renderer):
    """A mug dropped 1 m onto study_loft's rug and onto its bare concrete floor: on the rug
    the floor under it rings, struck through the pile (a soft contact: ms long), so the mug's
    kHz modes barely start. Much quieter (soft floor coverings improve impact sound by
    20-35 dB, ISO 10140-3 measurements of carpets) and duller."""
    from fallgen.physics.drop import record_drop

    variant = "study_loft-l1-m1"
    v = world.variant(variant)
    rug = next(it for it in v.furniture if it.type == "rug").parts[0].box
    others = [p.box for it in v.furniture if it.type != "rug" for p in it.parts]
    lo, hi = rug.aabb()
    spot = next((x, y) for x in np.linspace(lo[0] + 0.25, hi[0] - 0.25, 12)
                for y in np.linspace(lo[1] + 0.25, hi[1] - 0.25, 9)
                if not any(b.contains(np.array([[x, y, 0.3]]), tol=0.15)[0] for b in others))
    floor = max((z for z in v.zones if z.kind == "floor"),
                key=lambda z: z.volume.half[0] * z.volume.half[1])
    under = next(z for z in v.zones if z.anchor == "table.under")  # on the rug
    quat = np.asarray((0.96, 0.2, 0.1, 0.15))
    quat /= np.linalg.norm(quat)
    spec = ObjectSpec("cup", "mug", "ceramic", 1.0)
    on_rug = record_drop(world, variant, under, spec, (*spot, 1.0), quat, 900, (), "test")
    on_floor = record_drop(world, variant, floor, spec, (*floor.volume.center[:2], 1.0), quat,
                           900, (), "test")
    assert on_rug.contacts[0].other == "rug" and on_floor.contacts[0].other == "floor"
    rug_parts = renderer.render_bodies(on_rug, np.random.default_rng(0))
    rung = [p for name, p in rug_parts.items() if name.startswith("rug#")]
    assert len(rung) == 1  # the floor under the rug rings, struck through it
    # ... as the floor model has the slab struck through the rug (its first impact alone)
    one, c = _first_impact(on_rug)
    first = {n: p for n, p in renderer.render_bodies(one, np.random.default_rng(0)).items()
             if n.startswith("rug#")}
    (p_rug,) = first.values()
    _check_floor_hit(p_rug, _floor_reference_j(world, on_rug, c))
    a = np.sum(list(rug_parts.values()), axis=0)
    b = renderer.render(on_floor, np.random.default_rng(0))
    assert 20 * np.log10(np.abs(b).max() / np.abs(a).max()) > 20
    assert _centroid_hz(a) < 500 < 2000 < _centroid_hz(b)


def test_sources_split_the_fall_by_place_and_sum_to_it(world, renderer, drop_event):
    e = drop_event(world, "key", "house", "metal/brass", 1.0)
    total = renderer.render(e, np.random.default_rng(2))
    srcs = renderer.render_sources(e, np.random.default_rng(2), cluster_m=0.05)
    assert len(srcs) >= 1
    summed = np.sum([s.signal for s in srcs], axis=0)
    # equal up to modes pruned 80 dB below each render's loudest
    assert np.abs(summed - total).max() < 1e-3 * np.abs(total).max()
    pts = np.array([c.point_world for c in e.contacts])
    for s in srcs:  # every source sits where some contact happened
        assert np.min(np.linalg.norm(pts - s.position, axis=1)) < 1e-9
    one = renderer.render_sources(e, np.random.default_rng(2), cluster_m=100.0)
    assert len(one) == 1


def test_default_bodies_are_the_recording_scenes(world, renderer, drop_event):
    """Without a scene, the bodies hit are the room's geoms (a model compiled once per variant)
    and the other objects where they were placed: the same sound, sample for sample, as with
    the very scene that recorded the fall (a furniture part and a rotated distractor hit)."""
    yaw = 0.7
    coaster = Placement(ObjectSpec("coaster", "tile", "ceramic", 1.0), (5.0, 3.1, 0.755),
                        (float(np.cos(yaw / 2)), 0.0, 0.0, float(np.sin(yaw / 2))))
    e = drop_event(world, "key", "house", "metal/brass", 1.3, zone_kind="table_top",
                   distractors=(coaster,))
    others = {c.other for c in e.contacts}
    assert "obj:d0" in others
    assert any(not (is_panel(o) or o.startswith("obj:")) for o in others), others
    objs = [PlacedObject("target", world.categories.instance("key", "house", "metal/brass"),
                         e.start_pos, e.start_quat),
            PlacedObject("d0", world.categories.instance("coaster", "tile", "ceramic"),
                         coaster.pos, coaster.quat, free=False)]
    scene = build_scene(world.variant(e.room_variant), world.materials, objs, settings=PHYSICS)
    ref = renderer.render_sources(e, np.random.default_rng(3), scene)
    got = renderer.render_sources(e, np.random.default_rng(3))
    assert len(got) == len(ref)
    for a, b in zip(got, ref):
        assert np.array_equal(a.position, b.position)
        assert np.array_equal(a.signal, b.signal)


def test_model_budget_keeps_recent_models_and_the_same_sound(world, renderer, drop_event):
    """A renderer over its model budget drops the least recently used models and loads them
    again when needed (from the modal cache): the sound is the same."""
    e = drop_event(world, "key", "house", "metal/brass", 1.2, zone_kind="table_top")
    assert any(not is_panel(c.other) for c in e.contacts)  # a furniture part: 2 voxel models
    small = FallRenderer(world, renderer.s, model_budget_bytes=1)  # room for one model
    ref = renderer.render(e, np.random.default_rng(4))
    for _ in range(2):
        assert np.array_equal(small.render(e, np.random.default_rng(4)), ref)
        assert len(small._models) == 1
    assert small._model_bytes == sum(_nbytes(m) for m in small._models.values())
    # a model loaded again carries the surface moments computed at its first load, and its
    # shapes are read from the cache file where they are indexed (not held in memory)
    (key, model), = small._models.items()
    assert model.moments is small._moments[key]
    assert _nbytes(model) < model.shapes.nbytes
    assert len(small._moments) >= 2
    big = FallRenderer(world, renderer.s)
    big.render(e, np.random.default_rng(4))
    assert len(big._models) >= 2
    assert big._model_bytes == sum(_nbytes(m) for m in big._models.values())


def _energy_ratio(renderer, e) -> float:
    sources = renderer.render_sources(e, np.random.default_rng(0))
    return sum(radiated_energy_j(src.signal, FS) for src in sources) / renderer.energy_lost_j(e)


#: The largest share of an impact's lost energy measured in sound (hard, heavy impacts:
#: ~1e-4 to 1e-2; Koss & Alfredson 1973, Akay 1978)
MEASURED_SHARE = (1e-4, 1e-2)


@pytest.fixture(scope="module")
def every_category(world, renderer, drop_event):
    """Every target category in every material its first variant comes in, dropped 1 m onto
    study_loft's concrete floor, and a steel toaster from 1.5 m: (case, energy share,
    radiated energy, the floor model's energy for its first impact, mass)."""
    cats = world.categories
    cases = [(cid, cats.categories[cid].variants[0].name, mat, 1.0)
             for cid in cats.ids("target")
             for mat in sorted(cats.categories[cid].variants[0].materials)]
    cases.append(("toaster", "steel", "metal/appliance", 1.5))
    out = []
    for cid, variant, mat, height in cases:
        e = drop_event(world, cid, variant, mat, height)
        sources = renderer.render_sources(e, np.random.default_rng(0))
        radiated = sum(radiated_energy_j(src.signal, FS) for src in sources)
        c = next(c for c in e.contacts if c.kind == "impact")
        assert c.other == "floor", (cid, c.other)
        out.append(((cid, variant, mat, height), radiated / renderer.energy_lost_j(e), radiated,
                    _floor_reference_j(world, e, c),
                    cats.instance(cid, variant, mat).mass_kg))
    return out


def _check_share(share, radiated, floor_ref):
    """A fall radiates at most the largest measured share (1e-2, below AUDIO_ENERGY_CEILING)
    and at least its first impact's floor sound by the floor model, within 6 dB (a contact
    that chatters shares its impulse among several pulses, whose floor sound lies below one
    rigid hit's; the fall's other contacts and the object's own sound come on top)."""
    assert share <= min(MEASURED_SHARE[1], AUDIO_ENERGY_CEILING), share
    assert radiated >= floor_ref / 4, (radiated, floor_ref)


def test_every_category_radiates_a_bounded_share_of_what_its_fall_loses(world, every_category):
    """The energy account: a fall's sound carries at most the largest share of the energy an
    impact loses that has been measured (1e-2: a toaster's thin panels took 9-49 % when the
    modes were handed the rigid-body impulse whatever the wall could take), and at least what
    the floor model (checked against EN ISO 12354-2 and the ISO tapping machine) says its
    first impact's floor hit radiates, for every target category."""
    for case, share, radiated, ref, _ in every_category:
        try:
            _check_share(share, radiated, ref)
        except AssertionError as err:
            raise AssertionError(f"{case}: {err}") from None
    assert len({case[0] for case, *_ in every_category}) == \
        len(world.categories.ids("target"))
    # the check rejects a silent fall, one 20 dB too loud, and a constant share at the
    # 5 % ceiling
    case, share, radiated, ref, _ = max(every_category, key=lambda r: r[1])
    for wrong in ((share * 1e-3, radiated * 1e-3), (share * 100, radiated * 100),
                  (AUDIO_ENERGY_CEILING, radiated)):
        with pytest.raises(AssertionError):
            _check_share(*wrong, ref)


@pytest.mark.xfail(strict=True, reason=(
    "measured hard, heavy impacts radiate 1e-4..1e-2 of what they lose (Koss & Alfredson "
    "1973, Akay 1978); dropped 1 m onto concrete, a 377 g sheet-steel bookend radiates "
    "2.9e-5, a 145 g steel watch 6.9e-5, a 138 g aluminium iPod 2.3e-5 and a 104 g table "
    "knife 5.0e-6 (glassware, ceramics and the toaster lie in the range). Their thin walls' "
    "modes take 0.02-0.84 J at the first impact but radiate 2e-7..5e-4 of it: the compact "
    "monopole + dipole of a sheet's two faces cancel (a 1.5 mm sheet's dipole is its "
    "thickness times its area, a free plate's is its added mass, (8/3) a^3 for a disk, "
    "Lamb's Hydrodynamics), and at efficiency 1 their modes alone would radiate 1e-3..2e-1 "
    "of the fall's loss"))
def test_hard_heavy_falls_radiate_the_measured_share(every_category):
    """Hard (glass, ceramic, metal), heavy (>= 100 g) bodies falling onto concrete are the
    impacts the measured range describes."""
    hard = ("glass", "ceramic", "metal")
    low = [(case, share) for case, share, _, _, mass in every_category
           if case[2].split("/")[0] in hard and mass >= 0.1 and share < MEASURED_SHARE[0]]
    assert low == [], low


def test_a_wedged_contacts_excess_impulse_makes_no_sound(world, renderer, drop_event):
    """An impact's recorded impulse far above (1 + e) m v (an object pinched between two
    surfaces, squeezed by resting forces) sounds like the largest impact a free body could
    make at that speed: 20 and 40 times m v give the same sound."""
    e = drop_event(world, "key", "house", "metal/brass", 1.0)
    i = next(k for k, c in enumerate(e.contacts) if c.kind == "impact")
    c = e.contacts[i]
    m = world.categories.instance("key", "house", "metal/brass").mass_kg
    sounds = []
    for factor in (20, 40):
        hit = dataclasses.replace(c, impulse_ns=factor * m * c.normal_speed_mps)
        ev = dataclasses.replace(e, contacts=e.contacts[:i] + (hit,) + e.contacts[i + 1:])
        sounds.append(renderer.render(ev, np.random.default_rng(0)))
    assert np.array_equal(sounds[0], sounds[1])
    assert _energy_ratio(renderer, ev) <= AUDIO_ENERGY_CEILING


def test_a_held_part_rings_but_is_not_jerked_as_a_free_body(world, renderer, drop_event):
    """A ceramic jug dropped into a basket: the basket's parts (held by the rest of the basket
    and its support) only ring, within 10 dB of the jug itself; jerked as free bodies, their
    light bottom panel clicked at ~137 dB at 1 m, 15 dB above the jug (then 122 dB)."""
    from fallgen.audio.impact import render

    e = drop_event(world, "jug", world.categories.categories["jug"].variants[0].name,
                   "ceramic", 1.2, zone_kind="basket")
    parts = renderer.render_bodies(e, np.random.default_rng(0))
    held = {k: p for k, p in parts.items() if "#" in k}
    assert held, parts.keys()
    jug = float(np.abs(parts["target"]).max())
    # ringing only, the bottom panel is within a few dB of the jug (110 against 105 dB at 1 m)
    assert all(float(np.abs(p).max()) < 3 * jug for p in held.values())
    lost = renderer.energy_lost_j(e)
    assert all(radiated_energy_j(p, FS) < AUDIO_ENERGY_CEILING * lost for p in parts.values())
    # the parts' sound is their modes' alone
    target, others, _ = renderer._bodies(e, np.random.default_rng(0), None)
    for name, b in others:
        if "#" in name:
            assert not b.free
            modal = render(b.sounding, b.hits, renderer.s.length_s, FS, volume_m3=None)
            assert np.array_equal(b.render(renderer.s), modal)


def test_room_surfaces_are_the_six_faces_not_a_wall_cabinet():
    """A furniture id may start with "wall" (kitchen_dining's "wall_cab_n"): a part, not a
    room surface (the check by prefix rendered a wall cabinet as a wall)."""
    assert is_panel("floor") and is_panel("wall_north") and is_panel("ceiling")
    assert not is_panel("wall_cab_n") and not is_panel("wall_shelf")


@pytest.mark.parametrize("surface", ["glass_window", "gypsum_board", "wood_planks",
                                     "concrete_bare"])
@pytest.mark.parametrize("rigid", [False, True])
def test_a_surface_yields_as_the_large_plate_it_is(world, build_renderer, surface, rigid,
                                                   monkeypatch):
    """However stiff the contact, the force on a room surface stays below its point impedance
    times the approach speed, Z v, Z = 8 sqrt(B m'') (a large plate; Cremer, Heckl &
    Petersson ch. 5): in a full build a 0.8 kg ceramic jug thrown against a 4 mm pane at
    2.3 m/s pushed it with 11 kN when the pane's patch model alone set the contact
    (Z v ~1.1 kN; now 0.7 kN, hertz.plate_contact). A light pane is where the bound acts.
    ``rigid``: the bodies' modes left out of the contact (it lasts the rigid Hertz time), as
    where a patch's few modes leave it stiff."""
    import math

    import fallgen.audio.fall as fall
    from fallgen.audio.coupling import coupled_impact
    from fallgen.physics.contacts import ContactEvent

    if rigid:
        monkeypatch.setattr(fall, "coupled_impact", lambda m, v, tc, bodies: coupled_impact(
            m, v, tc, [(w, 0 * b) for w, b in bodies]))
    renderer = build_renderer
    mats = world.materials
    finish = mats.object(mats.surface(surface).impact_material)
    near = 0.0  # the largest share of Z v a hit's force reaches
    for cid, var, mat in (("key", "house", "metal/brass"), ("jug", "ceramic", "ceramic"),
                          ("bookend", "marble", "stone")):
        obj = world.categories.instance(cid, var, mat)
        for v in (1.0, 3.0, 6.0):
            patch = renderer._surface_body(finish, mats.surface(surface), np.zeros(3), np.eye(3))
            target = renderer._object_body(obj, np.zeros(3), np.eye(3))
            j = 0.6 * obj.mass_kg * v
            pts = target.sounding.modes.points
            feet = pts[np.argsort(pts[:, 2])[:40:10]]  # struck on its foot, as falls strike
            for k, point in enumerate(feet):
                c = ContactEvent(0.1, "impact", "wall_east", 0, 1, mat, finish.name, (0, 0, 0),
                                 tuple(map(float, point)), (0.0, 0.0, 1.0), v, j, 0.0, 0.004,
                                 j / 0.004)
                renderer._add_hits(c, target, patch, np.random.default_rng(k))
            z = patch.point_impedance_n_s_m
            for hit in patch.hits:
                for _, jk, tk in hit.force_pulses():
                    peak = math.pi * jk / (2 * tk)  # a half-sine pulse's
                    assert peak <= z * v * (1 + 1e-9), (surface, cid, v, peak, z * v)
                    near = max(near, peak / (z * v))
    if surface == "glass_window" and rigid:  # the pane's impedance is what holds the force
        assert near > 0.5, near  # (2 / pi of Z v where the pane takes the whole impact)
    if surface == "concrete_bare":  # a slab: the contact's own stiffness sets the force
        assert near < 0.05, near
