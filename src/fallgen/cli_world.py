"""The world's commands: ``rooms`` (list, check, show, acoustics, export), ``objects`` (list,
show) and ``materials list``."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Optional

import typer
from rich.table import Table

from fallgen.cli_common import DataDir, console, load_world_dir, variants
from fallgen.errors import InputError

commands = typer.Typer()
rooms = typer.Typer(help="Room variants: list, check, draw, acoustics, export to MJCF.",
                    no_args_is_help=True)
objects = typer.Typer(help="Object categories: list, check.", no_args_is_help=True)
materials = typer.Typer(help="Object and surface materials.", no_args_is_help=True)
commands.add_typer(rooms, name="rooms")
commands.add_typer(objects, name="objects")
commands.add_typer(materials, name="materials")


def register(app: typer.Typer, *_) -> None:
    """Add these commands to the ``fallgen`` app."""
    app.add_typer(commands)


# --- rooms --------------------------------------------------------------------------------------

@rooms.command("list")
def rooms_list(
    pattern: Annotated[str, typer.Argument(help="Glob over variant or room ids.")] = "*",
    data_dir: DataDir = None,
) -> None:
    """List room variants: id, kind, size, furniture and zones."""
    world = load_world_dir(data_dir)
    t = Table(title=f"room variants ({world.root})")
    for col in ("id", "kind", "size (m)", "furniture", "zones", "floor", "walls"):
        t.add_column(col)
    vs = variants(world, pattern)
    for v in vs:
        t.add_row(v.id, v.kind, " x ".join(f"{x:g}" for x in v.size_m), str(len(v.furniture)),
                  str(len(v.zones)), v.surfaces["floor"].name, v.surfaces["north"].name)
    console.print(t)
    kinds = {k: sum(v.kind == k for v in vs) for k in sorted({v.kind for v in vs})}
    console.print(f"{len(vs)} variants: " + ", ".join(f"{n} {k}" for k, n in kinds.items()))


@rooms.command("check")
def rooms_check(
    pattern: Annotated[str, typer.Argument(help="Glob over variant or room ids.")] = "*",
    data_dir: DataDir = None,
) -> None:
    """Check layouts geometrically (overlaps, zone supports, navigability); exit 1 on problems."""
    from fallgen.world.validate import check_variant

    world = load_world_dir(data_dir)
    bad = 0
    for v in variants(world, pattern):
        problems = check_variant(v)
        for p in problems:
            console.print(f"[red]{v.id}[/red]: {p}", highlight=False)
        bad += bool(problems)
    if bad:
        console.print(f"{bad} variant(s) with problems")
        raise typer.Exit(1)
    console.print("all variants ok")


@rooms.command("show")
def rooms_show(
    room: Annotated[str, typer.Argument(help="Variant id (or a glob; then -o is a directory).")],
    out: Annotated[Path, typer.Option("-o", "--out", help="PNG file, or directory for a glob.")],
    data_dir: DataDir = None,
) -> None:
    """Draw a top-down plan of a variant with furniture and numbered fall zones."""
    from fallgen.world.preview import draw_variant, write_png

    world = load_world_dir(data_dir)
    vs = variants(world, room)
    if len(vs) == 1 and out.suffix.lower() == ".png":
        targets = [(vs[0], out)]
    elif out.suffix:
        raise InputError("<command line>", "--out", f"{room!r} matches {len(vs)} variants: "
                         "give a directory, not a file")
    else:
        targets = [(v, out / f"{v.id}.png") for v in vs]
    images = [(draw_variant(v), p) for v, p in targets]  # draw everything before writing
    for img, p in images:
        write_png(img, p)
        console.print(f"wrote {p}")


def _acoustics_table(r) -> Table:
    """One variant's acoustics (:class:`fallgen.audio.acoustics.RoomReport`) as a table."""
    t = Table(title=f"{r.variant}: V {r.volume_m3:.1f} m^3, S {r.surface_m2:.1f} m^2 "
              f"({r.furniture_parts} furniture parts, {r.furniture_area_m2:.1f} m^2), "
              f"mean free path {r.mean_free_path_m:.2f} m")
    t.add_column("")
    for fc in r.bands_hz:
        t.add_column(f"{fc:g} Hz", justify="right")
    rows = [("RT60 model (Arau-Puchades), s", r.rt60_s), ("T30 rendered, s", r.t30_s),
            ("Eyring, s", r.eyring_s), ("Sabine, s", r.sabine_s),
            ("Fitzroy, s", r.fitzroy_s), ("bare room (Eyring), s", r.bare_eyring_s)]
    if r.raytrace_t30_s is not None:
        rows[2:2] = [("T30 ray tracer, s", r.raytrace_t30_s),
                     ("T20 ray tracer, s", r.raytrace_t20_s),
                     ("ray tracer T30 / model", r.rays_over_model)]
    rows += [("absorption area, m^2", r.absorption_area_m2),
             ("  of it furniture, m^2", r.furniture_absorption_m2)]
    for name, vals in rows:
        t.add_row(name, *[f"{x:.2f}" for x in vals])
    return t


def _acoustics_summary(reports, raytrace: bool) -> Table:
    """Many variants' acoustics, a row each."""
    t = Table(title=f"{len(reports)} variants: RT60 of the furnished room (model) and T30 "
              "of a rendered response, s")
    rays = ("rays T30 500 Hz-1 kHz", "rays T20", "rays / model") if raytrace else ()
    for col in ("variant", "V m^3", "mean free path m", "125 Hz", "500 Hz", "1 kHz",
                "4 kHz", "T30 500 Hz-1 kHz") + rays:
        t.add_column(col, justify="left" if col == "variant" else "right")
    for r in reports:
        row = [r.variant, f"{r.volume_m3:.1f}", f"{r.mean_free_path_m:.2f}",
               *[f"{r.rt60_s[b]:.2f}" for b in (0, 2, 3, 5)],
               f"{r.t30_s[2:4].mean():.2f}"]
        if raytrace:
            row += [f"{r.raytrace_t30_s[2:4].mean():.2f}", f"{r.raytrace_t20_s[2:4].mean():.2f}",
                    f"{r.rays_over_model[2:4].mean():.2f}"]
        t.add_row(*row)
    return t


@rooms.command("acoustics")
def rooms_acoustics(
    room: Annotated[str, typer.Argument(help="Variant id (or a glob).")],
    as_json: Annotated[bool, typer.Option("--json", help="Print JSON (one object per variant; "
                                          "rt60_s: 7 values, 125 Hz to 8 kHz).")] = False,
    out: Annotated[Optional[Path], typer.Option(
        "-o", "--out", help="PNG of the decay curves (a directory for a glob).")] = None,
    raytrace: Annotated[bool, typer.Option(
        "--raytrace", help="Also trace rays through the furnished room, the reference (one "
        "variant: every band, ~1-4 min; several: 500 Hz and 1 kHz, ~5-70 s each) and judge "
        "the RT60 goal on them.")] = False,
    data_dir: DataDir = None,
) -> None:
    """A variant's furnished acoustics: RT60 per octave band (the renderer's model beside
    Eyring, Sabine, Fitzroy and the bare room) and T30 measured on a rendered response, the
    mean free path, the absorption; a PNG of the decay curves. With --raytrace the ray
    tracer's T30 and T20 beside them, their ratio to the model, and the RT60 goal's verdict
    on the rays."""
    import json

    from fallgen.audio.acoustics import MID_BANDS, decay_png, rays_goal_line, room_report

    world = load_world_dir(data_dir)
    vs = variants(world, room)
    if out is not None and len(vs) > 1 and out.suffix:
        raise InputError("<command line>", "--out", f"{room!r} matches {len(vs)} variants: "
                         "give a directory, not a file")
    reports = [room_report(v, world.materials, raytrace=raytrace,
                           bands=None if len(vs) == 1 else MID_BANDS) for v in vs]
    for r in reports:
        if out is not None:
            decay_png(out if len(vs) == 1 and out.suffix else out / f"{r.variant}.png", r)
        if as_json:
            print(json.dumps(r.as_dict()))
    if len(reports) > 1 and not as_json:  # one row per variant
        console.print(_acoustics_summary(reports, raytrace))
    if len(reports) == 1 and not as_json:
        console.print(_acoustics_table(reports[0]))
    if raytrace and not as_json:
        console.print(rays_goal_line(reports))
    if out is not None and not as_json:
        console.print(f"wrote {len(reports)} PNG(s) under {out}")


@rooms.command("export")
def rooms_export(
    room: Annotated[str, typer.Argument(help="Variant id, e.g. kitchen_galley-l1-m1.")],
    out: Annotated[Path, typer.Option("-o", "--out", help="MJCF file to write.")],
    data_dir: DataDir = None,
) -> None:
    """Write a variant as MJCF that MuJoCo's viewer loads (python -m mujoco.viewer --mjcf=FILE)."""
    from fallgen.atomic import write_text
    from fallgen.world.scene import to_mjcf

    world = load_world_dir(data_dir)
    vs = variants(world, room)
    if len(vs) != 1:
        raise InputError("<command line>", "ROOM", f"{room!r} matches {len(vs)} variants; "
                         "export takes exactly one")
    write_text(out, to_mjcf(vs[0], world.materials))
    console.print(f"wrote {out}")


# --- objects ------------------------------------------------------------------------------------

@objects.command("list")
def objects_list(
    role: Annotated[Optional[str], typer.Option(help="target or occluder")] = None,
    data_dir: DataDir = None,
) -> None:
    """List object categories with their variants, materials, sizes and masses."""
    world = load_world_dir(data_dir)
    lib = world.categories
    t = Table(title="object categories")
    for col in ("category", "role", "variant", "materials", "size (mm)", "mass (g)"):
        t.add_column(col)
    for cat in lib:
        if role and cat.role != role:
            continue
        for v in cat.variants:
            g = lib.geometry(cat.id, v.name)
            masses = [lib.instance(cat.id, v.name, m).mass_kg * 1000 for m in v.materials]
            size = " x ".join(f"{x * 1000:.0f}" for x in sorted(g.extents, reverse=True))
            mass = f"{min(masses):.1f}" if len(masses) == 1 else \
                f"{min(masses):.1f}-{max(masses):.1f}"
            t.add_row(cat.id, cat.role, v.name, ", ".join(v.materials), size, mass)
    console.print(t)
    console.print(f"{len(lib.ids('target'))} target categories, "
                  f"{len(lib.ids('occluder'))} occluders")


@objects.command("show")
def objects_show(
    out: Annotated[Path, typer.Option("-o", "--out", help="PNG file to write.")],
    category: Annotated[Optional[list[str]], typer.Argument(help="Categories (default: all).")]
    = None,
    cols: Annotated[int, typer.Option(min=1, max=20, help="Tiles per row.")] = 8,
    data_dir: DataDir = None,
) -> None:
    """Render a contact sheet of object variants (needs headless GL: MUJOCO_GL=egl or osmesa)."""
    from fallgen.world.gallery import contact_sheet
    from fallgen.world.preview import write_png

    world = load_world_dir(data_dir)
    for c in category or []:
        if c not in world.categories:
            raise InputError("<command line>", "CATEGORY", f"unknown category {c!r}")
    write_png(contact_sheet(world.categories, category or None, cols), out)
    console.print(f"wrote {out}")


# --- materials ----------------------------------------------------------------------------------

@materials.command("list")
def materials_list(data_dir: DataDir = None) -> None:
    """List object materials (physical and modal constants) and surface materials (absorption)."""
    from fallgen.world.materials import OCTAVE_BANDS_HZ, load_materials
    from fallgen.paths import data_root

    mats = load_materials(data_root(data_dir) / "materials")
    t = Table(title="object materials")
    for col in ("name", "audio", "rho kg/m3", "E GPa", "nu", "eta", "friction", "solref"):
        t.add_column(col)
    for m in mats.objects.values():
        t.add_row(m.name, m.audio, f"{m.density_kg_m3:g}", f"{m.youngs_modulus_pa / 1e9:.3g}",
                  f"{m.poisson_ratio:g}", f"{m.loss_factor:g}", f"{m.friction_sliding:g}",
                  f"{m.contact_timeconst_s:g}/{m.contact_dampratio:g}")
    console.print(t)
    t = Table(title="surface materials: absorption per octave band")
    for col in ("name", *(f"{int(b)}" for b in OCTAVE_BANDS_HZ), "sounds like", "uses"):
        t.add_column(col)
    for s in mats.surfaces.values():
        t.add_row(s.name, *(f"{a:.2f}" for a in s.absorption), s.impact_material,
                  ",".join(s.uses))
    console.print(t)

