"""How a scene's geoms are dressed for the camera: surface textures at their real size,
textures fitted to one face (a front's doors, a sofa's cushions), materials' gloss, and
objects' texture coordinates by box projection. :mod:`fallgen.world.scene` calls these while it
builds a model; what a texture looks like is :mod:`fallgen.vision.textures`' (its spec:
:mod:`fallgen.world.appearance`)."""

from __future__ import annotations

import mujoco
import numpy as np

from fallgen.world.look import LookDraw

#: Specular reflectance of a textured surface by texture kind (MuJoCo's material.specular; 0.5
#: is its default for everything): matte plaster, carpet and fabric, glazed tiles and polished
#: stone, brushed metal.
SPECULAR = {"plaster": 0.05, "concrete": 0.05, "brick": 0.03, "carpet": 0.0, "fabric": 0.02,
            "planks": 0.25, "veneer": 0.25, "tiles": 0.45, "stone": 0.4, "metal": 0.6,
            "wallpaper": 0.05, "print": 0.1, "spines": 0.05, "window": 0.5, "doors": 0.25,
            "cushions": 0.02}


#: How bright a window is with daylight behind it (MuJoCo's material emission: the share of its
#: colour it shows unlit).
WINDOW_EMISSION = 0.7
#: ... and a ceiling with the light the room throws back up at it (no inter-reflection is
#: rendered: lit by the fittings' uplights alone, a white ceiling came out dark grey).
CEILING_EMISSION = 0.3


def face_frame(center, half, room_centre) -> tuple[list[float], list[float]]:
    """(half sizes, quaternion) of a wall box (``half`` along the room's axes, thinnest
    across the wall) with its local z along the wall's normal into the room, x along the wall
    and y up: the same box."""
    thin = int(np.argmin(half))
    n = np.zeros(3)
    n[thin] = 1.0 if center[thin] < room_centre[thin] else -1.0
    up = np.array([0.0, 0.0, 1.0])
    along = np.cross(up, n)
    rot = np.column_stack([along, up, n])  # local x, y, z in the room frame (det +1)
    quat = np.zeros(4)
    mujoco.mju_mat2Quat(quat, rot.ravel())
    along_axis = int(np.argmax(np.abs(along)))
    return [half[along_axis], half[2], half[thin]], list(quat)


def thin_axis_up(half, quat, axis: int | None = None, front: bool = False
                  ) -> tuple[list[float], list[float]]:
    """(half sizes, quaternion) of the same box with its thinnest axis (or ``axis``) as local
    z (a 2D texture shows at its size on the box's +-z faces only: these become its
    largest, or those across ``axis``). ``front``: the box's front (local -y) as its +z face,
    x along its width and y up, so that a texture fitted to the face shows upright, its
    first row at the top."""
    half = np.asarray(half, float)
    k = 1 if front else int(np.argmin(half)) if axis is None else axis
    if k == 2:
        return list(half), list(quat)
    i, j = [a for a in (0, 1, 2) if a != k]
    base = np.zeros(9)
    mujoco.mju_quat2Mat(base, np.asarray(quat, float))
    cols = base.reshape(3, 3)
    z = -cols[:, k] if front else cols[:, k]
    x = cols[:, i]
    y = np.cross(z, x)  # right-handed: (x, y, z) with y = z cross x
    q = np.zeros(4)
    mujoco.mju_mat2Quat(q, np.column_stack([x, y, z]).ravel())
    return [half[i], half[j], half[k]], list(q)


#: Pixels per side of a texture fitted to one face (a front's doors, a sofa's cushions): flat
#: panels between anti-aliased lines, the same at half the resolution of a surface's texture.
FITTED_TEXTURE_PX = 64


def untinted(rgba) -> list[float]:
    """The colour a material gives a texture so that the textured surface has ``rgba``'s
    colour on average (textures are patterns around :data:`~fallgen.vision.textures.
    MEAN_LEVEL`)."""
    from fallgen.vision.textures import MEAN_LEVEL

    return [min(1.0, float(c) / MEAN_LEVEL) for c in rgba[:3]]


def dress_textured(spec: mujoco.MjSpec, g, texture, rgba, repeat: tuple[float, float] | None = None,
          emission: float = 0.0) -> None:
    """Draw geom ``g`` with ``texture`` (a :class:`~fallgen.world.appearance.TextureSpec`)
    tinted by ``rgba``: one MuJoCo texture per spec and one material per (texture, colour) in
    the spec, the texture repeated every ``texture.size_m`` metres of the geom's faces (or
    ``repeat`` times per metre along their x and y, from the corner: a texture fitted to a
    face); ``emission``: the share of its colour it shows unlit (a window: its own)."""
    from fallgen.vision.textures import texture_bytes

    tex_name = f"tex_{texture.key()}"
    if spec.texture(tex_name) is None:
        t = spec.add_texture(name=tex_name, type=mujoco.mjtTexture.mjTEXTURE_2D)
        w, h, n, data = texture_bytes(texture) if repeat is None \
            else texture_bytes(texture, FITTED_TEXTURE_PX)
        t.width, t.height, t.nchannel, t.data = w, h, n, data
    colour = untinted(rgba)
    window = texture.kind == "window"
    emission = WINDOW_EMISSION if window else emission
    mat_name = f"{tex_name}_" + "_".join(f"{c:.3f}" for c in colour) \
        + (f"_e{emission:.2f}" if emission else "")
    if spec.material(mat_name) is None:
        m = spec.add_material(name=mat_name)
        m.textures[mujoco.mjtTextureRole.mjTEXROLE_RGB] = tex_name
        m.texuniform = True
        # MuJoCo repeats a uniform texture every 2 / texrepeat metres of a face, from the
        # face's corner (measured: tests/vision/test_appearance.py)
        m.texrepeat = [2.0 * r for r in repeat] if repeat is not None else \
            [2.0 / texture.size_m, 2.0 / texture.size_m]
        # a window is opaque and bright with the daylight behind it (the flat view's glass is
        # a transparent tint on nothing: the room has no outside)
        m.rgba = [*colour, 1.0 if window else float(rgba[3])]
        m.emission = emission
        m.specular = SPECULAR.get(texture.kind, 0.2)
    g.material = mat_name
    # a geom's own colour overrides its material's (MuJoCo): the same, so the material's holds
    g.rgba = list(spec.material(mat_name).rgba)


#: Pixels per side of an object's texture (its cube map's faces).
OBJECT_TEXTURE_PX = 64

#: How glossy an object of each audio material looks (MuJoCo's material specular, shininess):
#: glass, glazed ceramic and metal shine, varnished wood and hard plastics a little, cloth,
#: paper, cardboard and foam hardly.
GLOSS: dict[str, tuple[float, float]] = {
    "glass": (0.9, 0.9), "metal": (0.8, 0.7), "ceramic": (0.6, 0.8), "stone": (0.4, 0.6),
    "plastic_hard": (0.4, 0.5), "wood_hard": (0.3, 0.4), "wood_medium": (0.25, 0.3),
    "wood_soft": (0.15, 0.2), "rubber": (0.1, 0.2), "leather": (0.2, 0.3),
    "plastic_soft_foam": (0.05, 0.1), "fabric": (0.02, 0.05), "paper": (0.05, 0.1),
    "cardboard": (0.05, 0.1),
}


def box_texcoords(vertices: np.ndarray, faces: np.ndarray, size_m: float
                  ) -> tuple[np.ndarray, np.ndarray]:
    """Texture coordinates of a mesh without any, at real size: each triangle takes the
    coordinates of its corners on the plane its normal is most nearly along (a box
    projection: the texture on every face as on a box's, one image every ``size_m`` metres).
    Returns (3F, 2) coordinates and their (F, 3) index per triangle corner (MuJoCo's
    ``usertexcoord`` and ``userfacetexcoord``: a corner shared by triangles projected on
    different planes gets a coordinate per triangle)."""
    v = np.asarray(vertices, float)
    f = np.asarray(faces, np.int64)
    tri = v[f]  # (F, 3, 3)
    normal = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    axis = np.argmax(np.abs(normal), axis=1)
    # the plane's two other axes, in order (x: y, z; y: x, z; z: x, y)
    first = np.where(axis == 0, 1, 0)
    second = np.where(axis == 2, 1, 2)
    rows = np.arange(len(f))[:, None]
    uv = np.stack([tri[rows, np.arange(3)[None, :], first[:, None]],
                   tri[rows, np.arange(3)[None, :], second[:, None]]], axis=-1) / size_m
    return uv.reshape(-1, 2), np.arange(3 * len(f)).reshape(-1, 3)


def dress_object(spec: mujoco.MjSpec, g, material, rgba, look: LookDraw | None,
                 mapped: bool = False) -> None:
    """Draw an object's visual mesh as its material looks: glossy or matte by its audio
    material, and with the material's texture where it has one: on a mesh with texture
    coordinates at real size (``mapped``: :func:`box_texcoords`) as a flat texture, else (a
    plant's foliage, an ellipsoid) as a cube texture, which MuJoCo projects from the geom's
    centre by direction (its grain then scales with the geom, not with metres)."""
    from fallgen.vision.textures import texture_bytes

    texture = material.texture
    if texture is not None and look is not None:
        texture = look.texture(texture)
    name = f"obj_{material.name}" + (f"_{texture.key()}" if texture is not None else "") \
        + ("_uv" if mapped and texture is not None else "") \
        + "_" + "_".join(f"{c:.3f}" for c in rgba)
    if spec.material(name) is None:
        m = spec.add_material(name=name)
        m.specular, m.shininess = GLOSS.get(material.audio, (0.3, 0.3))
        m.rgba = list(rgba)
        if texture is not None:
            kind = "tex2d" if mapped else "cube"
            tex_name = f"{kind}_{texture.key()}_{OBJECT_TEXTURE_PX}"
            if spec.texture(tex_name) is None:
                t = spec.add_texture(name=tex_name, type=mujoco.mjtTexture.mjTEXTURE_2D
                                     if mapped else mujoco.mjtTexture.mjTEXTURE_CUBE)
                # 64 px: an object a few metres away covers a few dozen pixels of a view
                w, h, n, data = texture_bytes(texture, OBJECT_TEXTURE_PX)
                if mapped:
                    t.width, t.height, t.nchannel, t.data = w, h, n, data
                else:
                    t.width, t.height, t.nchannel, t.data = w, 6 * h, n, data * 6  # every face
            m.textures[mujoco.mjtTextureRole.mjTEXROLE_RGB] = tex_name
            if mapped:  # the coordinates are in texture images already
                m.texuniform = False
                m.texrepeat = [1.0, 1.0]
            else:
                m.texuniform = True
                m.texrepeat = [2.0 / texture.size_m, 2.0 / texture.size_m]
            m.rgba = [*untinted(rgba), rgba[3]]
    g.material = name
    g.rgba = list(spec.material(name).rgba)  # the geom's colour would override the material's
