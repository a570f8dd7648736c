"""Room variant (+ dropped object, distractors, occluders, a static agent) -> MuJoCo model.

Built through ``mujoco.MjSpec`` so nothing goes through XML on the hot path; ``to_mjcf`` writes
the same model as MJCF for MuJoCo's own viewer. Contact settings follow what settled small
objects cleanly in our measurements (``shared/design/physics-and-audio.md``): 2 ms steps,
elliptic friction cones, impratio 10, condim 6 (torsional and rolling friction) on loose
objects, zero margin, per-material friction and solref; and the ``implicitfast`` integrator:
with Euler, thin spinning objects (forks, spoons, toothbrushes) diverged to NaN at impact in
~1 % of drops (3 of 200 in two rooms), implicitfast had none for ~10 % more time per step.

Naming, which later stages rely on to label contacts and segmentation:
``floor``, ``ceiling``, ``wall_<side>``; ``<furniture id>/<part>``; a loose object's body is
``obj:<name>`` with a visual geom ``obj:<name>/visual`` (group 1, no collisions) and convex
collision geoms ``obj:<name>/cNN`` (group 3, hidden); the agent is body ``agent``.
"""

from __future__ import annotations

import dataclasses
import zlib
from collections import OrderedDict
from collections.abc import Sequence
from dataclasses import dataclass, field

import mujoco
import numpy as np

from fallgen.world.appearance import TextureSpec
from fallgen.world.dressing import CEILING_EMISSION, box_texcoords, dress_object, \
    dress_textured, face_frame, thin_axis_up
from fallgen.world.furniture import FURNITURE
from fallgen.world.look import LookDraw
from fallgen.world.materials import MaterialLibrary
from fallgen.world.objects import ObjectInstance
from fallgen.world.rooms import RoomVariant

WALL_THICKNESS_M = 0.2
#: MuJoCo ``geom.solimp`` of every geom: the constraint impedance ramps from 0 at first touch to
#: 0.95 at 1 mm of penetration. MuJoCo's default (0.9 at first touch) makes a body resting on a
#: contact with a bouncy ``solref`` chatter forever in a discrete-time limit cycle (a key on a
#: table: 0.02 m/s, never settles); the ramp removes it, costs ~0.5 mm of resting sink, and leaves
#: the restitution at impact speeds >= 1 m/s unchanged (measured; bench/contact_params.py).
CONTACT_SOLIMP = (0.0, 0.95, 0.001, 0.5, 2.0)
VISUAL_GROUP, COLLISION_GROUP = 1, 3



#: Geom owners of a room's walls (a furniture id may start with "wall" too: "wall_cab_n").
WALL_OWNERS = ("wall_west", "wall_east", "wall_south", "wall_north")

@dataclass(frozen=True)
class PhysicsSettings:
    timestep_s: float = 0.002
    impratio: float = 10.0
    elliptic_cone: bool = True
    object_condim: int = 6
    integrator: str = "implicitfast"
    #: MuJoCo's no-slip post-solver. Off: it triples the cost of a step. (With full-resolution
    #: hulls a key resting on a table rocked at ~0.3 rad/s without it; with coarse hulls no
    #: longer. Measured on 180 rehearsal trials: no-slip 0/1/3 with 32-vertex hulls kept 92/96/93
    #: at 4.1/3.3/2.6 kept events per second.)
    noslip_iterations: int = 0
    #: Hull vertices kept per convex collision piece (MuJoCo ``mesh.maxhullvert``): compiling a
    #: 17-piece bowl takes 23 ms with full hulls, 7 ms with 64 vertices and 4 ms with 32, and
    #: narrow-phase collision gets cheaper; coarse hulls also stop flat objects from rocking on
    #: the many near-coplanar contacts of a finely rounded base (a 32-vertex sphere hull is
    #: within ~3 % of the sphere).
    max_hull_vertices: int = 32
    #: Visual (render) meshes; physics-only scenes (rehearsal, replay) leave them out, which
    #: changes no physics (they do not collide) but the geom ids.
    visual_meshes: bool = True
    #: The objects' convex collision pieces; a scene that is only looked at (an episode's
    #: settled room: its views, lines of sight and occupancy) leaves them out: compiling them
    #: and uploading them to the renderer was ~40 % of making such a scene.
    collision_meshes: bool = True
    #: How the room looks (:mod:`fallgen.vision.textures`): its surfaces and furniture drawn
    #: with their materials' textures at real size, and ceiling lights that cast shadows.
    #: Scenes that are only simulated leave it out (textures add ~1 MB to a model).
    appearance: bool = False
    #: With ``appearance``: draw the room's textures, colours and lights from this seed
    #: (:class:`fallgen.world.look.LookDraw`; None: the room's own look).
    look_seed: int | None = None

    def __post_init__(self) -> None:
        if self.look_seed is not None and not self.appearance:
            raise ValueError("look_seed needs appearance (a look is drawn on textured scenes)")
        if not (self.visual_meshes or self.collision_meshes):
            raise ValueError("objects need visual or collision meshes (or both)")
        if not 0 < self.timestep_s <= 0.01:
            raise ValueError(f"timestep_s {self.timestep_s} out of range (0, 0.01]")
        if self.object_condim not in (1, 3, 4, 6):
            raise ValueError("object_condim must be 1, 3, 4 or 6")


#: An episode's settled room, only looked at (rendered, ray cast, rasterised): no collision pieces.
VIEW = PhysicsSettings(collision_meshes=False)
#: The same, drawn with textures and a shadow-casting light (what a build renders unless its
#: ``[generate]`` says ``appearance = false``).
LOOK = PhysicsSettings(collision_meshes=False, appearance=True)


@dataclass(frozen=True)
class PlacedObject:
    """An object in the scene: ``free`` ones fall, the others are fixed (frozen distractors,
    placed occluders)."""

    name: str
    instance: ObjectInstance
    pos: tuple[float, float, float]
    quat: tuple[float, float, float, float] = (1.0, 0.0, 0.0, 0.0)
    free: bool = True


@dataclass(frozen=True)
class AgentBody:
    """The robot as a static vertical cylinder (static, so replays stay bit-identical)."""

    x: float
    y: float
    yaw: float = 0.0
    radius_m: float = 0.2
    height_m: float = 1.2


@dataclass
class Scene:
    """A compiled scene and what each geom is (owner, material) for labelling contacts."""

    model: mujoco.MjModel
    spec: mujoco.MjSpec
    variant: RoomVariant
    geom_owner: tuple[str, ...]  # "floor", "ceiling", "wall_<side>", "<furniture id>", "obj:<name>", "agent"
    geom_material: tuple[str, ...]  # object material reference a hit on the geom sounds like
    object_body: dict[str, int] = field(default_factory=dict)  # object name -> body id

    def data(self) -> mujoco.MjData:
        return mujoco.MjData(self.model)


def _rgba(c) -> list[float]:
    return [float(x) for x in c]



def _set_contact(g, mats: MaterialLibrary, material: str, friction_sliding: float | None = None):
    m = mats.object(material)
    fr = list(m.friction)
    if friction_sliding is not None:
        fr[0] = friction_sliding
    g.friction = fr
    g.solref = list(m.solref)
    g.solmix = m.solmix
    g.solimp = list(CONTACT_SOLIMP)
    g.margin = 0.0


def build_spec(
    variant: RoomVariant,
    mats: MaterialLibrary,
    objects: Sequence[PlacedObject] = (),
    agent: AgentBody | None = None,
    settings: PhysicsSettings = PhysicsSettings(),
) -> tuple[mujoco.MjSpec, dict[str, tuple[str, str]]]:
    """The scene's MjSpec and, per geom name, its (owner, material). The room's part (options,
    shell, lights, furniture) is built once per variant and copied (:func:`room_spec`)."""
    room, room_info = room_spec(variant, mats, settings)
    spec = room.copy()
    info = dict(room_info)
    # the objects' own draws (the room's look is drawn once per variant and seed, then kept)
    look = None if settings.look_seed is None else LookDraw(settings.look_seed + 1)
    for obj in objects:
        _add_object(spec, mats, obj, settings, info, look)

    if agent is not None:
        body = spec.worldbody.add_body()
        body.name = "agent"
        body.pos = [agent.x, agent.y, 0.0]
        body.quat = [np.cos(agent.yaw / 2), 0.0, 0.0, np.sin(agent.yaw / 2)]
        g = body.add_geom()
        g.name = "agent/body"
        g.type = mujoco.mjtGeom.mjGEOM_CYLINDER
        g.size = [agent.radius_m, agent.height_m / 2, 0.0]
        g.pos = [0.0, 0.0, agent.height_m / 2 + 0.005]
        g.rgba = [0.2, 0.2, 0.22, 1.0]
        _set_contact(g, mats, "plastic_hard")
        info[g.name] = ("agent", "plastic_hard")
    return spec, info


#: Room specs kept (:func:`room_spec`): a generation shard visits every variant of its kind.
ROOM_SPECS_KEPT = 64
_ROOM_SPECS: OrderedDict[tuple, tuple[RoomVariant, MaterialLibrary, mujoco.MjSpec, dict]] = \
    OrderedDict()


def room_spec(variant: RoomVariant, mats: MaterialLibrary,
              settings: PhysicsSettings = PhysicsSettings()
              ) -> tuple[mujoco.MjSpec, dict[str, tuple[str, str]]]:
    """The room's own spec (options, shell, lights, furniture; no objects) and its geoms'
    (owner, material), made once per (variant, materials, settings) object and kept (the
    least recently used of more than ``ROOM_SPECS_KEPT`` dropped). Callers copy it, never
    change it: building the ~100 geoms in Python costs ~1 ms, a copy ~0.07 ms, and the
    compiled model is the same, byte for byte."""
    key = (id(variant), id(mats), settings)
    hit = _ROOM_SPECS.get(key)
    if hit is not None and hit[0] is variant and hit[1] is mats:
        _ROOM_SPECS.move_to_end(key)
        return hit[2], hit[3]
    spec, info = _build_room_spec(variant, mats, settings)
    _ROOM_SPECS[key] = (variant, mats, spec, info)  # the objects held keep their ids unique
    while len(_ROOM_SPECS) > ROOM_SPECS_KEPT:
        _ROOM_SPECS.popitem(last=False)
    return spec, info


def _build_room_spec(variant: RoomVariant, mats: MaterialLibrary, settings: PhysicsSettings
                     ) -> tuple[mujoco.MjSpec, dict[str, tuple[str, str]]]:
    spec = mujoco.MjSpec()
    # one thread: MuJoCo's threaded compile makes the same model and costs more (a worker per
    # core already keeps the cores busy): 18.8 ms against 24.1 ms for a room with 3 objects
    spec.compiler.usethread = False
    spec.modelname = variant.id
    spec.compiler.degree = False
    opt = spec.option
    opt.timestep = settings.timestep_s
    opt.impratio = settings.impratio
    opt.noslip_iterations = settings.noslip_iterations
    opt.cone = mujoco.mjtCone.mjCONE_ELLIPTIC if settings.elliptic_cone else mujoco.mjtCone.mjCONE_PYRAMIDAL
    opt.integrator = {
        "euler": mujoco.mjtIntegrator.mjINT_EULER,
        "implicitfast": mujoco.mjtIntegrator.mjINT_IMPLICITFAST,
        "rk4": mujoco.mjtIntegrator.mjINT_RK4,
    }[settings.integrator]
    spec.visual.headlight.ambient = [0.35, 0.35, 0.35]
    spec.visual.headlight.diffuse = [0.3, 0.3, 0.3]
    spec.stat.extent = float(max(variant.size_m))
    spec.stat.center = [variant.size_m[0] / 2, variant.size_m[1] / 2, variant.size_m[2] / 2]

    info: dict[str, tuple[str, str]] = {}
    wb = spec.worldbody
    lx, ly, h = variant.size_m
    t = WALL_THICKNESS_M
    look = None if settings.look_seed is None else LookDraw(settings.look_seed)
    lit = list if look is None else look.light  # a light's colour in the room's look

    def shell(name: str, surface_key: str, center, half) -> None:
        s = variant.surfaces[surface_key]
        g = wb.add_geom()
        g.name, g.type = name, mujoco.mjtGeom.mjGEOM_BOX
        g.pos, g.size = list(center), list(half)
        g.rgba = _rgba(s.rgba)
        if settings.appearance and s.texture is not None:
            if name.startswith("wall_"):
                # the same box with its local z along the wall's normal: MuJoCo maps a 2D
                # texture onto a box's faces by their local x and y, so only the +-z faces
                # show it at its size (on the others it smears into streaks)
                g.size, g.quat = face_frame(center, half, (lx / 2, ly / 2))
            # the ceiling is lit by the light the room throws back up, which a renderer without
            # inter-reflection leaves out: it shows some of its own colour unlit
            glow = CEILING_EMISSION if name == "ceiling" else 0.0
            if look is None:
                dress_textured(spec, g, s.texture, s.rgba, emission=glow)
            else:
                g.rgba = look.colour(("surface", s.name), s.rgba)
                dress_textured(spec, g, look.texture(s.texture), g.rgba, emission=glow)
        _set_contact(g, mats, s.impact_material, s.friction_sliding)
        info[name] = (name, s.impact_material)

    shell("floor", "floor", (lx / 2, ly / 2, -t / 2), (lx / 2 + t, ly / 2 + t, t / 2))
    shell("ceiling", "ceiling", (lx / 2, ly / 2, h + t / 2), (lx / 2 + t, ly / 2 + t, t / 2))
    shell("wall_south", "south", (lx / 2, -t / 2, h / 2), (lx / 2 + t, t / 2, h / 2))
    shell("wall_north", "north", (lx / 2, ly + t / 2, h / 2), (lx / 2 + t, t / 2, h / 2))
    shell("wall_west", "west", (-t / 2, ly / 2, h / 2), (t / 2, ly / 2, h / 2))
    shell("wall_east", "east", (lx + t / 2, ly / 2, h / 2), (t / 2, ly / 2, h / 2))

    for i, (x, y) in enumerate(((lx / 3, ly / 3), (2 * lx / 3, 2 * ly / 3))):
        light = wb.add_light()
        light.name = f"ceiling_light{i}"
        light.pos = [x, y, h - 0.05]
        light.dir = [0.0, 0.0, -1.0]
        light.diffuse = lit([0.22, 0.22, 0.21] if settings.appearance else [0.45, 0.45, 0.43])
        light.castshadow = False
        if settings.appearance:  # the fitting lights the ceiling around it too
            up = wb.add_light()
            up.name = f"ceiling_light{i}_up"
            up.pos = [x, y, h - 0.3]
            up.dir = [0.0, 0.0, 1.0]
            up.diffuse = lit([0.2, 0.2, 0.19])
            up.cutoff = 80.0
            up.castshadow = False
    if settings.appearance:
        # the room's main fitting, in the middle, casts shadows (one light only: each costs a
        # depth pass of the scene per colour view, ~14 ms of a 300 px view on a CPU renderer)
        main = wb.add_light()
        main.name = "ceiling_light_main"
        main.pos = [lx / 2, ly / 2, h - 0.05]
        main.dir = [0.0, 0.0, -1.0]
        main.diffuse = lit([0.45, 0.45, 0.43])
        main.cutoff = 70.0
        main.castshadow = True

    for item, part in variant.parts():
        g = wb.add_geom()
        g.name = f"{item.id}/{part.name}"
        b = part.box
        if part.shape == "cylinder":
            g.type = mujoco.mjtGeom.mjGEOM_CYLINDER
            g.size = [b.half[0], b.half[2], 0.0]
        elif part.shape == "ellipsoid":
            g.type = mujoco.mjtGeom.mjGEOM_ELLIPSOID
            g.size = list(b.half)
        else:
            g.type = mujoco.mjtGeom.mjGEOM_BOX
            g.size = list(b.half)
        g.pos = list(b.center)
        g.quat = list(b.quat)
        g.rgba = _rgba(part.rgba or mats.object(part.material).rgba)
        if look is not None:
            g.rgba = look.colour(("part", item.id, part.role), g.rgba)
        texture = mats.object(part.material).texture
        fitted = FURNITURE[item.type].fronts.get(part.name) if part.shape == "box" else None
        if settings.appearance and fitted is not None:
            # doors and drawers, cushions: a texture fitted to one face of the part
            kind, face, params = fitted
            fw = 2 * b.half[0]
            if face == "front":  # local -y
                fh = 2 * b.half[2]
                g.size, g.quat = thin_axis_up(b.half, b.quat, front=True)
            else:  # the top: already its +z face
                fh = 2 * b.half[1]
            texture = TextureSpec.make(kind, **params, face_w_m=round(fw, 4),
                                       face_h_m=round(fh, 4))
            if look is not None:
                texture = look.texture(texture)
            dress_textured(spec, g, texture, g.rgba, repeat=(1.0 / fw, 1.0 / fh))
        elif settings.appearance and texture is not None and part.shape == "ellipsoid":
            # a curved part shows its texture as an object does: a cube map (a flat texture
            # is projected along the geom's z and smears down its sides)
            dress_object(spec, g, mats.object(part.material), g.rgba, look)
        elif settings.appearance and texture is not None:
            if part.shape == "box":  # its largest faces as the box's +-z (see face_frame);
                # books show their spines: their front, whatever their proportions
                g.size, g.quat = thin_axis_up(b.half, b.quat,
                                               1 if texture.kind == "spines" else None)
            if texture.kind == "print":  # every picture its own image
                texture = dataclasses.replace(
                    texture, seed=zlib.crc32(f"{variant.room}/{item.id}".encode()))
            if look is not None:
                texture = look.texture(texture)
            dress_textured(spec, g, texture, g.rgba)
        _set_contact(g, mats, part.material)
        if part.decor:  # drawn, in the robot's way, never touched by a falling object
            g.contype = g.conaffinity = 0
        info[g.name] = (item.id, part.material)
    return spec, info


def _add_object(spec: mujoco.MjSpec, mats: MaterialLibrary, obj: PlacedObject,
                settings: PhysicsSettings, info: dict[str, tuple[str, str]],
                look: LookDraw | None = None) -> None:
    inst = obj.instance
    s = inst.scale
    geo = inst.geometry
    prefix = f"obj:{obj.name}"
    body = spec.worldbody.add_body()
    body.name = prefix
    body.pos = list(obj.pos)
    body.quat = list(obj.quat)
    if obj.free:
        j = body.add_freejoint()
        j.name = prefix
    body.explicitinertial = True
    body.mass = inst.mass_kg
    body.ipos = list(inst.com)
    body.fullinertia = [*np.diag(inst.inertia), inst.inertia[0, 1], inst.inertia[0, 2],
                        inst.inertia[1, 2]]
    body.inertia = [0.0, 0.0, 0.0]
    if settings.visual_meshes:
        vis = spec.add_mesh()
        vis.name = f"{prefix}/visual"
        vis.uservert = (geo.vertices * s).ravel().tolist()
        vis.userface = geo.faces.ravel().tolist()
        vis.inertia = mujoco.mjtMeshInertia.mjMESH_INERTIA_SHELL
        texture = inst.material.texture
        mapped = settings.appearance and texture is not None
        if mapped:  # the material's texture at its real size on the object
            uv, corners = box_texcoords(geo.vertices * s, geo.faces, texture.size_m)
            vis.usertexcoord = uv.ravel().tolist()
            vis.userfacetexcoord = corners.ravel().tolist()
        g = body.add_geom()
        g.name = f"{prefix}/visual"
        g.type = mujoco.mjtGeom.mjGEOM_MESH
        g.meshname = vis.name
        g.contype = g.conaffinity = 0
        g.group = VISUAL_GROUP
        g.rgba = _rgba(inst.material.rgba)
        if settings.appearance:
            if look is not None:
                g.rgba = look.colour(("object", obj.name), g.rgba)
            dress_object(spec, g, inst.material, g.rgba, look, mapped=mapped)
        info[g.name] = (prefix, inst.material.name)
    for k, piece in enumerate(geo.collision if settings.collision_meshes else ()):
        m = spec.add_mesh()
        m.name = f"{prefix}/c{k:02d}"
        m.uservert = (piece * s).ravel().tolist()
        m.inertia = mujoco.mjtMeshInertia.mjMESH_INERTIA_CONVEX
        m.maxhullvert = settings.max_hull_vertices
        c = body.add_geom()
        c.name = m.name
        c.type = mujoco.mjtGeom.mjGEOM_MESH
        c.meshname = m.name
        c.group = COLLISION_GROUP
        c.condim = settings.object_condim
        c.rgba = [0.9, 0.2, 0.2, 0.4]
        _set_contact(c, mats, inst.material.name)
        info[c.name] = (prefix, inst.material.name)


def build_scene(
    variant: RoomVariant,
    mats: MaterialLibrary,
    objects: Sequence[PlacedObject] = (),
    agent: AgentBody | None = None,
    settings: PhysicsSettings = PhysicsSettings(),
) -> Scene:
    """Compile a variant (plus objects and an optional static agent) into a MuJoCo model."""
    spec, info = build_spec(variant, mats, objects, agent, settings)
    model = spec.compile()
    owners, materials = [], []
    for gid in range(model.ngeom):
        owner, material = info[model.geom(gid).name]
        owners.append(owner)
        materials.append(material)
    bodies = {o.name: model.body(f"obj:{o.name}").id for o in objects}
    return Scene(model, spec, variant, tuple(owners), tuple(materials), bodies)


def to_mjcf(variant: RoomVariant, mats: MaterialLibrary, objects: Sequence[PlacedObject] = (),
            agent: AgentBody | None = None) -> str:
    """MJCF text of the scene, loadable by ``mujoco.MjModel.from_xml_string`` and the viewer."""
    spec, _ = build_spec(variant, mats, objects, agent)
    spec.compile()
    return spec.to_xml()
