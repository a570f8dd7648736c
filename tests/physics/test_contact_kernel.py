"""The compiled contact recorder against the Python reference (tests/physics/python_recorder.py):
the same events, bit for bit, whatever the number of steps per call; and the raw MuJoCo access
it rests on (mjraw) against the Python bindings."""

from __future__ import annotations

import importlib.util
import math
import sys
from pathlib import Path

import mujoco
import numpy as np
import pytest

from fallgen.physics import mjraw
from fallgen.physics.contacts import KINDS, ContactRecorder
from fallgen.world.scene import PhysicsSettings, PlacedObject, build_scene


def _reference():
    name = "fallgen_tests_python_recorder"
    if name not in sys.modules:  # (registered before it runs: it defines dataclasses)
        spec = importlib.util.spec_from_file_location(
            name, Path(__file__).with_name("python_recorder.py"))
        sys.modules[name] = module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
    return sys.modules[name].PythonRecorder


VARIANT = "study_loft-l1-m1"


def _scene(world, name):
    v = world.variant(VARIANT)
    pyramidal = PhysicsSettings(elliptic_cone=False)
    return build_scene(v, world.materials, _objects(world, name),
                       settings=pyramidal if name.endswith("pyramidal") else PhysicsSettings())


def _spot(world):
    v = world.variant(VARIANT)
    z = max((z for z in v.zones if z.kind == "floor"),
            key=lambda z: z.volume.half[0] * z.volume.half[1])
    return float(z.volume.center[0]), float(z.volume.center[1])


def _fresh(scene, qvel):
    m, d = scene.model, scene.data()
    b = scene.object_body["target"]
    vadr = m.jnt_dofadr[m.body_jntadr[b]]
    d.qvel[vadr:vadr + 6] = qvel
    mujoco.mj_forward(m, d)
    return m, d, b


def _values(events):
    return [tuple(vars(e).values()) for e in events]


# (category, variant, start height, orientation, initial velocity, a static object below);
# a name ending in "pyramidal": pyramidal friction cones (the scenes' own are elliptic)
CASES = {
    "cup_spinning": ("cup", "mug", 1.1, (0.96, 0.2, 0.1, 0.15), (0.3, -0.2, 0, 3, -2, 5), None),
    "can_rolling": ("soda_can", None, 0.2, (math.cos(math.pi / 4), math.sin(math.pi / 4), 0, 0),
                    (1.2, 0.3, 0, 0, 0, 0), None),
    "book_sliding": ("book", None, 0.08, (1, 0, 0, 0), (3.0, 0.3, -0.3, 0, 0, 2), None),
    "cup_onto_bowl": ("cup", "mug", 0.9, (0.9, 0.3, 0.2, 0.25), (0, 0, 0, 1, 0, 0), "bowl"),
    "spoon_sliding_pyramidal": ("spoon", None, 0.08, (1, 0, 0, 0), (3.0, 0.3, -0.3, 0, 0, 2),
                                None),
}


def _objects(world, name):
    cat, var, z0, quat, _, below = CASES[name]
    lib = world.categories
    var = var or lib[cat].variants[0].name
    inst = lib.instance(cat, var, sorted(lib[cat].variant(var).materials)[0])
    x, y = _spot(world)
    q = np.asarray(quat, float)
    objs = [PlacedObject("target", inst, (x, y, z0), tuple(q / np.linalg.norm(q)))]
    if below:
        b = lib.instance(below, lib[below].variants[0].name,
                         sorted(lib[below].variants[0].materials)[0])
        lo = (b.geometry.vertices * b.scale).min(axis=0)[2]
        objs.append(PlacedObject("o0", b, (x + 0.03, y, -float(lo) + 1e-4), free=False))
    return objs


@pytest.mark.parametrize("name", sorted(CASES))
@pytest.mark.parametrize("chunk", [1, 10, 37])
def test_compiled_recorder_matches_the_python_reference(world, name, chunk):
    scene = _scene(world, name)
    qvel = CASES[name][4]
    steps = 1500
    m, d, b = _fresh(scene, qvel)
    ref = _reference()(m, b, scene.geom_owner, scene.geom_material)
    qadr = m.jnt_qposadr[m.body_jntadr[b]]
    xs, ys = [d.qpos[qadr]], [d.qpos[qadr + 1]]
    for _ in range(steps):
        ref.before_step(d)
        mujoco.mj_step(m, d)
        ref.after_step(d)
        xs.append(d.qpos[qadr])
        ys.append(d.qpos[qadr + 1])
    m2, d2, _ = _fresh(scene, qvel)
    rec = ContactRecorder(m2, b, scene.geom_owner, scene.geom_material)
    done = 0
    while done < steps:
        n = min(chunk, steps - done)
        rec.step(d2, n)
        done += n
    assert rec.step_count == steps
    assert np.array_equal(d.qpos, d2.qpos) and np.array_equal(d.qvel, d2.qvel)
    events = rec.finish()
    expected = ref.finish()
    assert expected, f"{name}: nothing recorded"
    assert _values(events) == _values(expected)
    assert rec.sweep == ((min(xs), min(ys)), (max(xs), max(ys)))


def test_the_cases_cover_every_rule(world):
    """The reference comparison above means something only if its cases exercise every rule:
    every kind of event, contact with another object, slides that hop (re-contacts that are
    not impacts), and both kinds of friction cone."""
    kinds, others, hops, cones = set(), set(), 0, set()
    for name in CASES:
        scene = _scene(world, name)
        m, d, b = _fresh(scene, CASES[name][4])
        ref = _reference()(m, b, scene.geom_owner, scene.geom_material)
        is_hop = ref._is_hop

        def counted(*args, _is_hop=is_hop):
            nonlocal hops
            hop = _is_hop(*args)
            hops += hop
            return hop

        ref._is_hop = counted
        for _ in range(1500):
            ref.before_step(d)
            mujoco.mj_step(m, d)
            ref.after_step(d)
        ev = ref.finish()
        kinds |= {e.kind for e in ev}
        others |= {e.other for e in ev}
        cones.add(int(m.opt.cone))
    assert kinds == set(KINDS)
    assert "obj:o0" in others and "floor" in others
    assert hops > 0
    assert cones == {int(mujoco.mjtCone.mjCONE_PYRAMIDAL), int(mujoco.mjtCone.mjCONE_ELLIPTIC)}


def test_a_recorder_follows_one_data_and_is_finished_once(world):
    scene = _scene(world, "cup_spinning")
    m, d, b = _fresh(scene, CASES["cup_spinning"][4])
    rec = ContactRecorder(m, b, scene.geom_owner, scene.geom_material)
    rec.step(d, 5)
    with pytest.raises(ValueError, match="one MjData"):
        rec.step(scene.data(), 1)
    rec.finish()
    with pytest.raises(RuntimeError, match="finished"):
        rec.step(d, 1)


def test_event_arrays_grow_when_they_fill(world):
    """A recorder whose event arrays start nearly full grows them between steps and loses
    nothing."""
    scene = _scene(world, "book_sliding")
    m, d, b = _fresh(scene, CASES["book_sliding"][4])
    full = ContactRecorder(m, b, scene.geom_owner, scene.geom_material)
    full.step(d, 800)
    m2, d2, _ = _fresh(scene, CASES["book_sliding"][4])
    small = ContactRecorder(m2, b, scene.geom_owner, scene.geom_material)
    for name in ("_vf", "_vi", "_rank"):  # room for a single step's events only
        a = getattr(small, name)
        setattr(small, name, a[:2 * m.ngeom + 1].copy())
    small.step(d2, 800)
    assert len(small._vf) > 2 * m.ngeom + 1
    assert _values(small.finish()) == _values(full.finish())


def test_raw_layout_and_step_agree_with_the_bindings():
    """mjraw's offsets are checked on a live simulation; mj_step called by address steps
    exactly as the bindings' mj_step does."""
    import ctypes

    lay = mjraw.layout()
    xml = ('<mujoco><worldbody><geom type="plane" size="2 2 .1"/><body pos="0 0 .5">'
           '<freejoint/><geom type="box" size=".1 .05 .02"/></body></worldbody></mujoco>')
    m = mujoco.MjModel.from_xml_string(xml)
    d1, d2 = mujoco.MjData(m), mujoco.MjData(m)
    for d in (d1, d2):
        d.qvel[3:6] = (2.0, -1.0, 0.5)
    mujoco.mj_step(m, d1, nstep=400)
    rec = ContactRecorder(m, 1, ("floor", "obj:box"), ("wood", "plastic"))
    rec.step(d2, 400)
    assert np.array_equal(d1.qpos, d2.qpos) and np.array_equal(d1.qvel, d2.qvel)
    assert d1.ncon > 1  # the resting box touches the floor at its corners
    # the offsets, read off this simulation's own contacts through the bindings' arrays
    # (views into mjData's contact buffer: their addresses and stride)
    con = d2.contact
    base = con.dist.ctypes.data
    assert ctypes.c_void_p.from_address(d2._address + lay.contact).value == base
    assert ctypes.c_int.from_address(d2._address + lay.ncon).value == d2.ncon
    assert ctypes.c_void_p.from_address(d2._address + lay.efc_force).value == \
        d2.efc_force.ctypes.data
    assert con.pos.strides[0] == con.geom.strides[0] == lay.con_size
    for field, offset in (("pos", lay.con_pos), ("frame", lay.con_frame), ("dim", lay.con_dim),
                          ("geom", lay.con_geom), ("efc_address", lay.con_efc_address)):
        assert getattr(con, field).ctypes.data - base == offset, field
    # and the second contact's geoms read raw are the bindings' (floor 0, box 1)
    raw = (ctypes.c_int * 2).from_address(base + lay.con_size + lay.con_geom)
    assert list(raw) == list(con.geom[1]) == [0, 1]


def test_timers_off_stops_the_clock_and_changes_no_step():
    """With MuJoCo's profiling clock off, a step reads no clock (its timers stay at 0 s while
    they count the steps) and the simulation is the same to the bit as with the system clock;
    a second call is harmless."""
    xml = ('<mujoco><worldbody><geom type="plane" size="2 2 .1"/><body pos="0 0 .5">'
           '<freejoint/><geom type="box" size=".1 .05 .02"/></body></worldbody></mujoco>')
    m = mujoco.MjModel.from_xml_string(xml)
    before = mujoco.get_mjcb_time()
    runs = []
    try:
        for clock_off in (False, True, True):
            mujoco.set_mjcb_time(None)
            if clock_off:
                mjraw.timers_off()
                mjraw.timers_off()
            d = mujoco.MjData(m)
            d.qvel[3:6] = (2.0, -1.0, 0.5)
            mujoco.mj_step(m, d, nstep=300)
            step = d.timer[int(mujoco.mjtTimer.mjTIMER_STEP)]
            runs.append((d.qpos.copy(), d.qvel.copy(), step.duration, step.number))
    finally:
        mujoco.set_mjcb_time(before)
    (q0, v0, t0, n0), (q1, v1, t1, n1), _ = runs
    assert t0 > 0 and t1 == 0.0 and n0 == n1 == 300
    assert np.array_equal(q0, q1) and np.array_equal(v0, v1)
