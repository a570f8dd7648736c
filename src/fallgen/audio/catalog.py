"""Every modal model a build can need, and precomputing them into the cache.

Jobs: each object variant (except thin shells, whose modes are closed-form) in each Poisson
ratio its materials have; each furniture part (box or cylinder, from the compiled room scenes)
in its material's (room surfaces are closed-form plates). :class:`~fallgen.audio.fall.FallRenderer`
asks for exactly these, so after :func:`precompute` a build solves nothing.
"""

from __future__ import annotations

from collections.abc import Callable, Collection, Iterator
from dataclasses import dataclass
from pathlib import Path

import mujoco
import numpy as np

from fallgen.audio.modes import (ModalSettings, cache_key, cache_path, default_cache_dir,
                                 modal_model, round_nu)
from fallgen.pipeline.executor import parallel_map
from fallgen.world.library import World


@dataclass(frozen=True)
class ModalJob:
    label: str
    vertices: np.ndarray
    faces: np.ndarray
    nu: float


def jobs(world: World, variants: Collection[str] | None = None,
         objects: Collection[tuple[str, str, str]] | None = None,
         parts: Collection[tuple[str, int]] | None = None) -> list[ModalJob]:
    """Every modal model a build can need; or only those of the room ``variants`` (ids), of
    the ``objects`` ((category, variant, material) triples) and of the furniture ``parts``
    ((variant id, geom id) in the variant's scene without objects) when given."""
    from fallgen.audio.fall import is_panel, part_mesh
    from fallgen.world.scene import build_scene

    out: dict[tuple, ModalJob] = {}

    def add(label, mesh_v, mesh_f, nu):
        key = (cache_key(mesh_v, mesh_f, nu, ModalSettings()), round_nu(nu))
        out.setdefault(key, ModalJob(label, mesh_v, mesh_f, nu))

    lib, mats = world.categories, world.materials
    for cat in lib:
        for v in cat.variants:
            g = lib.geometry(cat.id, v.name)
            if g.shell is not None:  # closed-form shell modes: nothing to solve or cache
                continue
            for mname in v.materials:
                if objects is None or (cat.id, v.name, mname) in objects:
                    add(f"{cat.id}/{v.name}", g.vertices, g.faces,
                        mats.object(mname).poisson_ratio)
    # room surfaces are closed-form plates (audio.shells.plate_model): nothing to solve
    for room in world.rooms.values():
        for variant in room.variants:
            if variants is not None and variant.id not in variants:
                continue
            scene = build_scene(variant, mats, [])
            m = scene.model
            for gid in range(m.ngeom):
                owner = scene.geom_owner[gid]
                if is_panel(owner) or owner == "agent" or \
                        parts is not None and (variant.id, gid) not in parts:
                    continue
                if m.geom_contype[gid] == 0 and m.geom_conaffinity[gid] == 0:
                    continue  # decor: nothing strikes it
                gtype = int(m.geom_type[gid])
                mesh = part_mesh(gtype, m.geom_size[gid])
                kind = "cylinder" if gtype == int(mujoco.mjtGeom.mjGEOM_CYLINDER) else "box"
                add(f"{owner}/{kind}", mesh.vertices, mesh.faces,
                    mats.object(scene.geom_material[gid]).poisson_ratio)
    return list(out.values())


def _solve(args) -> str:
    job, settings, cache_dir = args
    modal_model(job.vertices, job.faces, job.nu, settings, cache_dir)
    return job.label


def missing(todo: list[ModalJob], settings: ModalSettings = ModalSettings(),
            cache_dir: Path | None = None) -> list[ModalJob]:
    """The jobs whose models are not in the cache yet."""
    return [j for j in todo
            if not cache_path(j.vertices, j.faces, j.nu, settings, cache_dir).exists()]


def precompute(world: World, settings: ModalSettings = ModalSettings(),
               cache_dir: Path | None = None, workers: int = 1,
               on_done: Callable[[str], None] | None = None,
               todo: list[ModalJob] | None = None) -> int:
    """Solve every job (of ``todo``, default: :func:`jobs`) not yet cached; returns how
    many there were in all."""
    todo = jobs(world) if todo is None else todo
    cache_dir = cache_dir or default_cache_dir()
    args = [(j, settings, cache_dir) for j in todo]
    it: Iterator[str] = map(_solve, args) if workers <= 1 or len(args) <= 1 else \
        parallel_map(_solve, args, _no_init, (), min(workers, len(args)))
    for label in it:
        if on_done:
            on_done(label)
    return len(todo)


def _no_init() -> None:
    pass
