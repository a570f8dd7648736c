"""Offscreen MuJoCo rendering with one GL context for many scenes.

``mujoco.Renderer`` makes a new OpenGL context for every model. On a CPU renderer (Mesa
llvmpipe, what a machine without a GPU has) that costs ~10 ms, and the first frame drawn in a
fresh context another ~70 ms (its shaders are compiled on first use), so a context per episode
cost more than the rest of the episode's renders. A :class:`GLContext` here lives as long as its
owner (a worker's episode maker); each scene gets a :class:`SceneFrames` on it, which holds only
the model's own MuJoCo render context (meshes, textures) and scene.

The pixels are those of ``mujoco.Renderer`` (same flags, same read-out, same depth
linearisation: tests/vision compares them).

A colour draw of a scene with a shadow-casting light costs three passes in ``mjr_render``: the
light's depth map (every geom, seen from the light), the scene without that light, and the
scene again with it, where the map says a point is lit. The map depends only on the geoms and
the light, not on the camera (the pass turns face culling off, and its projection takes only
the model's near and far planes from the camera), so while the scene stands still a
:class:`SceneFrames` draws it once: later colour draws of the same state send the depth pass
into a 1 x 1 framebuffer of their own (``mjrContext.shadowFBO`` pointed at it for the draw),
and the texture the lit pass reads still holds the map. With the map kept (or no map to
draw), a colour draw also leaves out the geoms that cannot reach the image, as segmentation
draws do: none of them casts a shadow into it any more. Both give the same pixels
(tests/vision/test_shadow_reuse.py); on a CPU renderer a textured view's colour draw took 8.7
instead of 16.9 ms (2-core Intel Xeon VM, the smoke build's rooms).
"""

from __future__ import annotations

import mujoco
import numpy as np

from fallgen.vision.contexts import FONT_SCALE, TextureNames, context_inputs, make_over

#: The auxiliary buffer of a MuJoCo context that a reused shadow map's depth pass draws into.
SHADOW_SINK_AUX = 0


class GLContext:
    """An offscreen OpenGL context (``MUJOCO_GL``: egl or osmesa) of ``size`` x ``size``.

    It also keeps one MuJoCo render context to lend to the scenes drawn in it one after
    another (:meth:`lend`), made over for each (:func:`fallgen.vision.contexts.make_over`):
    on a CPU renderer a render context cost 12-25 ms to make between the episodes of a build,
    most of it allocating and filling buffers, textures and display lists that are the same
    for every scene."""

    def __init__(self, size: int) -> None:
        from mujoco.rendering.classic.gl_context import GLContext as _Context

        self.size = size
        self._ctx = _Context(size, size)
        self._ctx.make_current()
        self._kept: mujoco.MjrContext | None = None  # the render context to lend
        self._kept_inputs: bytes | None = None  # its context_inputs
        self._lent = False
        self._textures = TextureNames()  # every texture uploaded in this GL context

    def make_current(self) -> None:
        self._ctx.make_current()

    def lend(self, model: mujoco.MjModel) -> mujoco.MjrContext:
        """A render context for ``model`` that draws what ``mujoco.MjrContext(model,
        FONT_SCALE)`` draws: the kept one made over for it when their
        :func:`~fallgen.vision.contexts.context_inputs` are the same, else a new one (kept
        from then on). Hand it back with :meth:`give_back` (one scene at a time; a second
        scene asking before the first gave it back gets a context of its own)."""
        self.make_current()
        inputs = context_inputs(model)
        if inputs is None or self._lent:
            return mujoco.MjrContext(model, FONT_SCALE)
        if self._kept is not None and self._kept_inputs == inputs:
            make_over(self._kept, model, self._textures)
        else:
            self._free_kept()
            self._kept = mujoco.MjrContext(model, FONT_SCALE)
            self._kept_inputs = inputs
            self._textures.adopt(self._kept, model)
        self._lent = True
        return self._kept

    def give_back(self, con: mujoco.MjrContext) -> None:
        """End a scene's use of ``con`` from :meth:`lend` (one not kept here is freed)."""
        if con is self._kept:
            self._lent = False
        else:
            self.make_current()
            con.free()

    def _free_kept(self) -> None:
        if self._kept is not None:
            self.make_current()
            self._kept.ntexture = 0  # its texture names are the GL context's (TextureNames)
            self._kept.free()
            self._kept, self._kept_inputs, self._lent = None, None, False

    def close(self) -> None:
        if self._ctx is not None:
            self._free_kept()
            self.make_current()
            self._textures.clear()
            self._ctx.free()
            self._ctx = None

    def __del__(self) -> None:
        # the kept render context and textures are freed in this GL context, not in whatever
        # context is current when the garbage collector gets to them (another camera's)
        try:
            self.close()
        except Exception:  # interpreter shutdown: GL may be gone
            pass


class SceneFrames:
    """RGB, depth (metres) and geom segmentation of one model, drawn in a shared context."""

    def __init__(self, model: mujoco.MjModel, context: GLContext, max_geom: int) -> None:
        self.model, self.context, self.size = model, context, context.size
        self._con: mujoco.MjrContext | None = context.lend(model)
        mujoco.mjr_setBuffer(mujoco.mjtFramebuffer.mjFB_OFFSCREEN.value, self._con)
        self._con.readDepthMap = mujoco.mjtDepthMap.mjDEPTH_ZEROFAR
        self._scene = mujoco.MjvScene(model=model, maxgeom=max_geom)
        self._option = mujoco.MjvOption()
        self._rect = mujoco.MjrRect(0, 0, self.size, self.size)
        self._table: np.ndarray | None = None
        self._culled = False  # the last draw left geoms out (its segment table is its own)
        #: segmentation draws leave out the geoms that cannot reach the pixels drawn
        self.cull = True
        off = np.flatnonzero(np.asarray(self._option.geomgroup) == 0)
        self._hidden_group = int(off[0]) if len(off) else None
        # an infinite plane has bounding radius 0: never left out
        self._radius = np.where(model.geom_rbound > 0, model.geom_rbound * (1 + 1e-3) + 1e-4,
                                np.inf)
        #: colour draws of a scene standing still reuse the light's shadow map (see the module)
        self.reuse_shadow_map = True
        #: colour draws leave out the geoms that cannot reach the image where nothing else
        #: needs them: no shadow map is drawn in them, no geom mirrors the room, and none lets
        #: it show through (their drawing order would be sorted anew)
        self.cull_colour = True
        self._shadow_fbo = int(self._con.shadowFBO)  # 0: no light casts shadows
        self._shadow_state: bytes | None = None  # what the map in the texture was drawn of
        self._sink: int | None = None  # the framebuffer a reused map's depth pass draws into
        has_mat = model.geom_matid >= 0
        mat = np.maximum(model.geom_matid, 0)
        # (a model without materials: no geom has one)
        reflectance = np.append(model.mat_reflectance, 0.0)[np.where(has_mat, mat, -1)]
        mat_alpha = np.append(model.mat_rgba[:, 3], 1.0)[np.where(has_mat, mat, -1)]
        self._mirrors = bool(np.any((reflectance > 0) & np.isin(
            model.geom_type, (mujoco.mjtGeom.mjGEOM_PLANE, mujoco.mjtGeom.mjGEOM_BOX))))
        see_through = (model.geom_rgba[:, 3] < 1) | (mat_alpha < 1)
        self._plain = not (self._mirrors or bool(see_through.any()))
        sky = bool(np.any(model.tex_type == mujoco.mjtTexture.mjTEXTURE_SKYBOX))
        #: whether a colour draw's depth buffer is the depth a segmentation draw reads (the
        #: same opaque triangles through the same projection): not where a geom mirrors the
        #: room or lets it show through (a colour draw keeps such geoms out of its depth), nor
        #: with a skybox (drawn into a colour draw's depth only)
        self.colour_depth_exact = self._plain and not sky

    def close(self) -> None:
        if self._con is not None:
            self.context.give_back(self._con)
            self._con = None

    def __del__(self) -> None:
        # A context dropped without close() would be freed by the garbage collector under
        # whatever GL context is current then, deleting that context's textures and buffers
        # (another camera's: its segmentation then read texture colours). Free it in its own.
        try:
            self.close()
        except Exception:  # interpreter shutdown: GL may be gone
            pass

    def _draw(self, data: mujoco.MjData, camera: mujoco.MjvCamera, ids: bool,
              crop: tuple[int, int, int, int] | None = None,
              read: tuple[int, int, int, int] | None = None) -> mujoco.MjrRect:
        """Draw the view; with ``crop`` = (row0, row1, col0, col1) only that part of the
        image, into the corner of the buffer (the frustum narrowed to it). ``read``: the only
        part of the image that will be read back. A segmentation draw leaves out the geoms
        that cannot reach the part drawn or read (:meth:`_outside`); so does a colour draw
        that reuses the shadow map (or has none to draw). The rect drawn."""
        reuse, state = False, None
        if not ids and self._shadow_fbo:
            state = self._static_state(data)
            reuse = self.reuse_shadow_map and state == self._shadow_state
        cull = self.cull if ids else (self.cull_colour and self._plain
                                      and (reuse or not self._shadow_fbo))
        hidden = self._outside(data, camera, crop or read) if cull else None
        self._culled = hidden is not None and bool(hidden.any())
        groups = self.model.geom_group
        if self._culled:
            # in a group the views do not draw for this update only (the segment ids of the
            # geoms drawn are then their places in a shorter list: see _segment_table)
            kept = groups[hidden]
            groups[hidden] = self._hidden_group
        try:
            mujoco.mjv_updateScene(self.model, data, self._option, None, camera,
                                   mujoco.mjtCatBit.mjCAT_ALL.value, self._scene)
        finally:
            if self._culled:
                groups[hidden] = kept
        if self._scene.ngeom >= self._scene.maxgeom:  # geoms were left out
            raise RuntimeError(f"the scene holds only {self._scene.maxgeom} geoms")
        flags = self._scene.flags
        # depth and segmentation are drawn with segment colours (as mujoco.Renderer does: the
        # depth is more accurate far away)
        flags[mujoco.mjtRndFlag.mjRND_SEGMENT] = ids
        flags[mujoco.mjtRndFlag.mjRND_IDCOLOR] = ids
        # shadows only in colour: a segment or depth draw has no use for the lights' depth
        # passes (one per shadow-casting light)
        flags[mujoco.mjtRndFlag.mjRND_SHADOW] = not ids
        rect = self._rect
        if crop is not None:
            r0, r1, c0, c1 = crop
            n = self.size
            for cam in self._scene.camera:  # (mjr_render takes the half width from the rect)
                half = 0.5 * (cam.frustum_top - cam.frustum_bottom)  # square: = half width
                left, bottom = cam.frustum_center - half, cam.frustum_bottom
                cam.frustum_center = left + half * (c0 + c1) / n
                cam.frustum_bottom = bottom + 2 * half * (n - r1) / n  # GL rows from the bottom
                cam.frustum_top = bottom + 2 * half * (n - r0) / n
            rect = mujoco.MjrRect(0, 0, c1 - c0, r1 - r0)
        self.context.make_current()
        if reuse:
            self._con.shadowFBO = self._shadow_sink()
        try:
            mujoco.mjr_render(rect, self._scene, self._con)
        finally:
            if reuse:
                self._con.shadowFBO = self._shadow_fbo
        if state is not None:
            self._shadow_state = state  # the texture holds this state's map now
        return rect

    def _static_state(self, data: mujoco.MjData) -> bytes:
        """What the shadow map depends on: where every geom and light is, and the geoms'
        sizes, colours and groups (the scene's list)."""
        m = self.model
        return b"".join(a.tobytes() for a in (data.geom_xpos, data.geom_xmat, data.light_xpos,
                                              data.light_xdir, m.geom_size, m.geom_rgba,
                                              m.geom_group, m.light_castshadow))

    def _shadow_sink(self) -> int:
        """A 1 x 1 framebuffer (an auxiliary buffer of the MuJoCo context) for the depth pass
        of a draw that reuses the map: its fragments all fall outside it (a lent context
        keeps the one an earlier scene made)."""
        if self._sink is None:
            con, aux = self._con, SHADOW_SINK_AUX
            if not (con.auxFBO[aux] and con.auxWidth[aux] == 1 and con.auxHeight[aux] == 1
                    and con.auxSamples[aux] == 0):
                mujoco.mjr_addAux(aux, 1, 1, 0, con)
                mujoco.mjr_setBuffer(mujoco.mjtFramebuffer.mjFB_OFFSCREEN.value, con)
            self._sink = int(con.auxFBO[aux])
        return self._sink

    def _outside(self, data: mujoco.MjData, camera: mujoco.MjvCamera,
                 crop: tuple[int, int, int, int] | None) -> np.ndarray | None:
        """The geoms whose bounding spheres lie wholly outside the view frustum (narrowed to
        ``crop``, image rows from the top), one pixel of slack on every side: none of their
        triangles can cover a pixel centre of the draw. A segmentation draw is flat colours
        without reflections, shadows or multisampling, in the order of the scene's list, so
        leaving them out changes no pixel, while a CPU renderer's cost of a small cropped
        draw is mostly the geometry of the whole room. None when there is no group to
        hide them in."""
        if self._hidden_group is None:
            return None
        az, el = np.radians(camera.azimuth), np.radians(camera.elevation)
        ca, sa, ce, se = np.cos(az), np.sin(az), np.cos(el), np.sin(el)
        f = np.array([ce * ca, ce * sa, se])  # the free camera's axes (see mjv_updateScene)
        r = np.array([sa, -ca, 0.0])
        u = np.array([-ca * se, -sa * se, ce])  # r x f
        eye = np.asarray(camera.lookat) - camera.distance * f
        half = self.size / 2
        t = np.tan(np.radians(self.model.vis.global_.fovy) / 2) / half  # per pixel
        r0, r1, c0, c1 = crop if crop is not None else (0, self.size, 0, self.size)
        # tangents of the four sides, grown by a pixel
        left, right = (c0 - 1 - half) * t, (c1 + 1 - half) * t
        low, high = (half - r1 - 1) * t, (half - r0 + 1) * t
        # outward unit normals of the side planes (through the eye)
        normals = np.array([left * f - r, r - right * f, low * f - u, u - high * f])
        normals /= np.linalg.norm(normals, axis=1)[:, None]
        dist = (data.geom_xpos - eye) @ normals.T  # (ngeom, 4)
        return (dist > self._radius[:, None]).any(axis=1)

    def rgb(self, data: mujoco.MjData, camera: mujoco.MjvCamera) -> np.ndarray:
        self._draw(data, camera, False)
        out = np.empty((self.size, self.size, 3), np.uint8)
        mujoco.mjr_readPixels(out, None, self._rect, self._con)
        return np.ascontiguousarray(np.flipud(out))

    def rgb_and_depth(self, data: mujoco.MjData, camera: mujoco.MjvCamera
                      ) -> tuple[np.ndarray, np.ndarray]:
        """RGB and depth (metres along the view axis) read from one colour draw; the depth of
        :meth:`depth_and_geoms` where :attr:`colour_depth_exact` (ValueError elsewhere)."""
        if not self.colour_depth_exact:
            raise ValueError("this scene's colour draws keep mirrors or see-through geoms out "
                             "of their depth: use depth_and_geoms")
        self._draw(data, camera, False)
        rgb = np.empty((self.size, self.size, 3), np.uint8)
        raw = np.empty((self.size, self.size), np.float32)
        mujoco.mjr_readPixels(rgb, raw, self._rect, self._con)
        return np.ascontiguousarray(np.flipud(rgb)), self._metres(raw)

    def depth_and_geoms(self, data: mujoco.MjData, camera: mujoco.MjvCamera
                        ) -> tuple[np.ndarray, np.ndarray]:
        """Depth (metres along the view axis) and :meth:`geoms` of the whole image, both read
        from one segmentation render (as ``mujoco.Renderer`` draws depth: segment colours are
        more accurate far away)."""
        self._draw(data, camera, True)
        rgb = np.empty((self.size, self.size, 3), np.uint8)
        raw = np.empty((self.size, self.size), np.float32)
        mujoco.mjr_readPixels(rgb, raw, self._rect, self._con)
        return self._metres(raw), self._geom_ids(rgb)

    def _metres(self, raw: np.ndarray) -> np.ndarray:
        """The depth buffer ``raw`` (bottom row first) as metres along the view axis."""
        extent = self.model.stat.extent
        znear = np.float32(self.model.vis.map.znear * extent)
        zfar = np.float32(self.model.vis.map.zfar * extent)
        # the perspective matrix's coefficients in float32 (as glFrustum has them), in
        # MuJoCo's reversed-Z mapping, then undone in float64
        c = -(zfar + znear) / (zfar - znear)
        d = -(np.float32(2) * zfar * znear) / (zfar - znear)
        c = np.float32(-0.5) * c - np.float32(0.5)
        d = np.float32(-0.5) * d
        metres = (d / (raw.astype(np.float64) + c)).astype(np.float32)
        return np.ascontiguousarray(np.flipud(metres))

    def geoms(self, data: mujoco.MjData, camera: mujoco.MjvCamera,
              window: tuple[int, int, int, int] | None = None, crop: bool = False
              ) -> np.ndarray:
        """(H, W) int64: the geom id seen at each pixel, -1 for none (or a non-geom). With
        ``window`` = (row0, row1, col0, col1) (image rows from the top), only that part of
        the image is read back (the same pixels; reading is most of a small render's cost on
        a CPU renderer). With ``crop`` as well, only that part is drawn, through the frustum
        narrowed to it (~3x faster for a small window on a CPU renderer): the same pixels up
        to rounding where an edge passes through a pixel centre (the projection matrix is
        another, in float32): about one pixel in 10^4 differs."""
        if window is not None and crop:
            rect = self._draw(data, camera, True, window)
        else:
            self._draw(data, camera, True, read=window)
            rect = self._rect
            if window is not None:
                r0, r1, c0, c1 = window
                rect = mujoco.MjrRect(c0, self.size - r1, c1 - c0, r1 - r0)  # GL rows: bottom up
        rgb = np.empty((rect.height, rect.width, 3), np.uint8)
        mujoco.mjr_readPixels(rgb, None, rect, self._con)
        return self._geom_ids(rgb)

    def _geom_ids(self, rgb: np.ndarray) -> np.ndarray:
        """The geom id of each pixel of a segmentation render ``rgb`` (bottom row first),
        image rows from the top; -1 for none."""
        c = rgb.astype(np.uint32)
        segid = c[..., 0] + c[..., 1] * (2 ** 8) + c[..., 2] * (2 ** 16)
        return np.ascontiguousarray(np.flipud(self._segment_table()[segid]))

    def _segment_table(self) -> np.ndarray:
        """Geom id of each segment colour (0: the background) of the scene last drawn. Every
        draw of one model lists the same geoms in the same order (MuJoCo culls nothing), so
        the table is made once per length of the list; a draw that left geoms out
        (:meth:`_outside`) gets a table of its own."""
        n = self._scene.ngeom
        if self._culled or self._table is None or len(self._table) != n + 1:
            table = np.full(n + 1, -1, np.int64)  # segment id 0 is the background
            geom = int(mujoco.mjtObj.mjOBJ_GEOM)
            for g in self._scene.geoms[:n]:
                if g.segid != -1 and g.objtype == geom and g.objid >= 0:
                    table[g.segid + 1] = g.objid
            if self._culled:  # a shorter list of this draw only
                return table
            self._table = table
        return self._table
