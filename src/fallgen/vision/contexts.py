"""A MuJoCo render context made over for another model, instead of made anew.

``mjr_makeContext`` allocates and fills, for every model, an offscreen framebuffer, a shadow
map, fonts, built-in shapes, the model's textures (with their mipmaps) and its meshes' display
lists. Between the episodes of a build (one scene each, in one GL context) that cost 12-25 ms
on a CPU renderer, where most of it is the same every time. :func:`make_over` gives a context
made for one model what ``mjr_makeContext`` would have given it for another whose
:func:`context_inputs` are the same (the same offscreen size, shadow map and shapes): its
materials' texture references, its meshes (uploaded into display lists the context holds),
the ranges that scale with its extent, and its textures, found by their content among those
already uploaded in the GL context (:class:`TextureNames`: a build's rooms and objects have a
few dozen) or uploaded as ``mjr_makeContext`` does. The pixels drawn are the same
(``tests/vision/test_lent_context.py``).
"""

from __future__ import annotations

import zlib

import mujoco
import numpy as np

#: Font scale of the render contexts (MuJoCo's mjFONTSCALE_150; no text is drawn).
FONT_SCALE = mujoco.mjtFontScale.mjFONTSCALE_150.value


def context_inputs(model: mujoco.MjModel) -> bytes | None:
    """What of ``model`` a render context holds besides its textures, materials, meshes and
    the ranges :func:`make_over` sets (``mjr_makeContext``: the offscreen and shadow buffers'
    sizes, the built-in shapes' resolution); None for a model whose context holds more
    (planes, height fields, skins, flexes: never made over)."""
    if (model.nhfield or model.nskin or getattr(model, "nflex", 0)
            or np.any(model.geom_type == mujoco.mjtGeom.mjGEOM_PLANE)):
        return None
    q, g = model.vis.quality, model.vis.global_
    return np.array((g.offwidth, g.offheight, q.offsamples, q.shadowsize, q.numslices,
                     q.numstacks, q.numquads), np.int64).tobytes()


class TextureNames:
    """The textures uploaded in one GL context, by content: what ``mjr_uploadTexture`` reads
    of a model's texture (its type, size, channels, colour space and bytes) -> the GL texture
    name holding it. Its names are deleted by :meth:`clear` (in that GL context), never by a
    render context (whose ``ntexture`` is set to 0 before it is freed)."""

    def __init__(self, limit: int = 256) -> None:
        self.limit = limit  # past this many, all are deleted and uploaded again as needed
        self._names: dict[tuple, list[tuple[bytes, int]]] = {}
        self._count = 0

    def __len__(self) -> int:
        return self._count

    @staticmethod
    def _content(model: mujoco.MjModel, i: int) -> tuple[tuple, bytes]:
        w, h = int(model.tex_width[i]), int(model.tex_height[i])
        n = int(model.tex_nchannel[i])
        adr = int(model.tex_adr[i])
        data = model.tex_data[adr:adr + w * h * n].tobytes()
        key = (int(model.tex_type[i]), w, h, n, int(model.tex_colorspace[i]), zlib.crc32(data))
        return key, data

    def _find(self, key: tuple, data: bytes) -> int | None:
        for held, name in self._names.get(key, ()):
            if held == data:
                return name
        return None

    def _add(self, key: tuple, data: bytes, name: int) -> None:
        self._names.setdefault(key, []).append((data, name))
        self._count += 1

    def adopt(self, con: mujoco.MjrContext, model: mujoco.MjModel) -> None:
        """Take over the textures ``mujoco.MjrContext(model, ...)`` uploaded into ``con``: a
        texture held already is drawn from the name holding it (the new one deleted)."""
        from OpenGL import GL

        for i in range(model.ntex):
            key, data = self._content(model, i)
            name = self._find(key, data)
            if name is None:
                self._add(key, data, int(con.texture[i]))
            else:
                GL.glDeleteTextures(1, [int(con.texture[i])])
                con.texture[i] = name

    def assign(self, con: mujoco.MjrContext, model: mujoco.MjModel) -> None:
        """Point ``con``'s first ``model.ntex`` texture names at ``model``'s textures,
        uploading those not held yet (``mjr_uploadTexture``, into new names)."""
        from OpenGL import GL

        if self._count + model.ntex > self.limit:
            self.clear()
        con.ntexture = model.ntex
        con.textureType[:model.ntex] = model.tex_type
        for i in range(model.ntex):
            key, data = self._content(model, i)
            name = self._find(key, data)
            if name is not None:
                con.texture[i] = name
                continue
            con.texture[i] = name = int(np.atleast_1d(GL.glGenTextures(1))[0])
            mujoco.mjr_uploadTexture(model, con, i)  # into the name just made
            self._add(key, data, name)

    def clear(self) -> None:
        """Delete every name held (in the current GL context, the one they were made in)."""
        from OpenGL import GL

        names = [name for held in self._names.values() for _, name in held]
        if names:
            GL.glDeleteTextures(len(names), names)
        self._names.clear()
        self._count = 0


def make_over(con: mujoco.MjrContext, model: mujoco.MjModel, textures: TextureNames) -> None:
    """Make ``con`` (made for a model whose :func:`context_inputs` are ``model``'s, its
    textures held by ``textures``) draw ``model`` as ``mujoco.MjrContext(model, ...)`` would:
    ``model``'s textures (:meth:`TextureNames.assign`), its materials' texture references, its
    meshes (into the context's display lists, a longer range of them when it has more meshes)
    and the shadow and fog ranges that scale with its extent. In the current GL context."""
    from OpenGL import GL

    GL.glGetError()  # (an error a draw before left unread is not this one's)
    textures.assign(con, model)
    # the materials' textures as mjr_makeContext sets them: a skybox's in the last slot, then
    # every material with an RGB texture
    roles = len(con.mat_texid) // len(con.mat_texuniform)
    rgb = int(mujoco.mjtTextureRole.mjTEXROLE_RGB)
    con.mat_texid[:] = -1
    con.mat_texuniform[:] = 0
    con.mat_texrepeat[:] = 0
    sky = np.flatnonzero(model.tex_type == mujoco.mjtTexture.mjTEXTURE_SKYBOX)
    if len(sky):
        con.mat_texid[roles * (len(con.mat_texuniform) - 1) + rgb] = int(sky[0])
    for i in np.flatnonzero(model.mat_texid[:, rgb] >= 0) if model.nmat else ():
        con.mat_texid[roles * i:roles * (i + 1)] = model.mat_texid[i]
        con.mat_texuniform[i] = model.mat_texuniform[i]
        con.mat_texrepeat[2 * i:2 * i + 2] = model.mat_texrepeat[i]
    if 2 * model.nmesh > con.rangeMesh:
        if con.rangeMesh:
            GL.glDeleteLists(con.baseMesh, con.rangeMesh)
        con.baseMesh = int(GL.glGenLists(2 * model.nmesh))
        con.rangeMesh = 2 * model.nmesh
    for i in range(model.nmesh):
        mujoco.mjr_uploadMesh(model, con, i)
    # the ranges that scale with the model's extent (a room's longest side), as
    # mjr_makeContext sets them, the fog's in the GL context too
    ext, mp = model.stat.extent, model.vis.map
    con.shadowClip = ext * mp.shadowclip
    con.shadowScale = mp.shadowscale
    con.fogStart = ext * mp.fogstart
    con.fogEnd = ext * mp.fogend
    con.fogRGBA[:] = model.vis.rgba.fog
    con.lineWidth = model.vis.global_.linewidth
    GL.glFogf(GL.GL_FOG_START, con.fogStart)
    GL.glFogf(GL.GL_FOG_END, con.fogEnd)
    GL.glFogfv(GL.GL_FOG_COLOR, np.asarray(con.fogRGBA, np.float32))
