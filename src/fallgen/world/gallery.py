"""A contact sheet of object variants, rendered headless with MuJoCo, for people to check.

Each tile shows one (category, variant) in its first material on a grey floor, framed from a
three-quarter view, labelled with its id, size and mass. Needs an OpenGL backend
(``MUJOCO_GL=egl`` or ``osmesa``; see the README).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import cv2
import numpy as np

from fallgen.world.objects import CategoryLibrary, ObjectInstance

TILE = 220
LABEL_H = 46


def _render_instance(inst: ObjectInstance, size: int = TILE) -> np.ndarray:
    import mujoco

    spec = mujoco.MjSpec()
    spec.visual.headlight.ambient = [0.45, 0.45, 0.45]
    spec.visual.headlight.diffuse = [0.5, 0.5, 0.5]
    spec.visual.global_.offwidth = size
    spec.visual.global_.offheight = size
    g = spec.worldbody.add_geom()
    g.type, g.size, g.rgba = mujoco.mjtGeom.mjGEOM_PLANE, [20, 20, 0.01], [0.82, 0.82, 0.8, 1]
    light = spec.worldbody.add_light()
    light.pos, light.dir, light.diffuse = [0.3, -0.3, 1.0], [-0.3, 0.3, -1.0], [0.5, 0.5, 0.5]
    mesh = spec.add_mesh()
    mesh.name = "obj"
    mesh.uservert = (inst.geometry.vertices * inst.scale).ravel().tolist()
    mesh.userface = inst.geometry.faces.ravel().tolist()
    mesh.inertia = mujoco.mjtMeshInertia.mjMESH_INERTIA_SHELL
    body = spec.worldbody.add_body()
    lo = inst.geometry.vertices.min(axis=0) * inst.scale
    body.pos = [0.0, 0.0, -lo[2]]
    og = body.add_geom()
    og.type, og.meshname = mujoco.mjtGeom.mjGEOM_MESH, "obj"
    og.rgba = list(inst.material.rgba)
    model = spec.compile()
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    ext = inst.extents_m
    cam = mujoco.MjvCamera()
    cam.lookat[:] = (0.0, 0.0, ext[2] / 2)
    cam.distance = 1.6 * float(np.linalg.norm(ext)) + 0.02
    cam.azimuth, cam.elevation = 135.0, -30.0
    r = mujoco.Renderer(model, size, size)
    try:
        r.update_scene(data, cam)
        return r.render().copy()
    finally:
        r.close()


def contact_sheet(lib: CategoryLibrary, categories: Sequence[str] | None = None,
                  cols: int = 8) -> np.ndarray:
    """RGB image with one labelled tile per (category, variant)."""
    tiles = []
    for cat in lib:
        if categories is not None and cat.id not in categories:
            continue
        for v in cat.variants:
            inst = lib.instance(cat.id, v.name, sorted(v.materials)[0])
            img = np.full((TILE + LABEL_H, TILE, 3), 255, np.uint8)
            img[LABEL_H:] = _render_instance(inst)[:, :, ::-1]
            dims = " x ".join(f"{x * 1000:.0f}" for x in sorted(inst.extents_m, reverse=True))
            for k, text in enumerate((f"{cat.id}/{v.name}",
                                      f"{dims} mm, {inst.mass_kg * 1000:.1f} g",
                                      inst.material.name)):
                cv2.putText(img, text, (4, 13 + 14 * k), cv2.FONT_HERSHEY_SIMPLEX, 0.37,
                            (10, 10, 10), 1, cv2.LINE_AA)
            tiles.append(img[:, :, ::-1])
    if not tiles:
        raise ValueError("no categories selected")
    rows = math.ceil(len(tiles) / cols)
    th = TILE + LABEL_H
    sheet = np.full((rows * th, min(cols, len(tiles)) * TILE, 3), 255, np.uint8)
    for i, t in enumerate(tiles):
        r, c = divmod(i, cols)
        sheet[r * th:(r + 1) * th, c * TILE:(c + 1) * TILE] = t
    return sheet
