"""Write the measured figures into the documentation (``make report``).

Every block of README.md and docs/*.md between ``<!-- generated: NAME -->`` and
``<!-- end: NAME -->`` is made again from the JSON that NAME's source wrote, with the date, the
machine (CPU model, cores) and the command that made it (from the ``X.provenance.json`` that
``bench/provenance.py`` writes beside each ``X.json``; ``make bench``, ``make bench-full``,
``make loudness``, ``make dataset`` and ``make table`` write both). A block whose JSON is absent
keeps what it says, and the report says so. The dataset's field tables come from
:mod:`fallgen.dataset.schema` itself.

    python bench/docs_report.py [--build build] [--root .]

Sources, under ``--build``:

- ``bench.json`` (``make bench``: ``bench/report.py`` merges the benchmarks' lines),
- ``bench-full.json`` (``make bench-full``: the paper-size build, timed),
- ``loudness.json`` (``make loudness``: floors under the tapping machine, reference drops),
- ``full-stats.json`` (``make dataset``: ``fallgen stats build/full --json``),
- ``table/table.json`` (``make table``: the paper's Table 1 and Table 2 on the build),
- ``hrtf.json`` (``make hrtf``: the audio module with the measured head and the spherical one).
"""

from __future__ import annotations

import argparse
import datetime
import json
import re
import sys
from collections.abc import Callable
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]

#: source name -> (file under the build directory, the command that makes it)
SOURCES = {
    "bench": ("bench.json", "make bench"),
    "bench_full": ("bench-full.json", "make bench-full"),
    "loudness": ("loudness.json", "make loudness"),
    "stats": ("full-stats.json", "make dataset"),
    "table": ("table/table.json", "make table"),
    "hrtf": ("hrtf.json", "make hrtf"),
}
BLOCK = re.compile(r"(?P<open><!-- generated: (?P<name>[\w-]+)[^\n]*?-->\n)(?P<body>.*?)"
                   r"(?P<close><!-- end: (?P=name) -->)", re.S)
#: What the documentation says where a figure's source has not been made yet.
NOT_YET = "*Not yet measured: run `{command}`, then `make report`.*\n"


class Source:
    """A result file and what made it."""

    def __init__(self, name: str, build: Path) -> None:
        rel, self.command = SOURCES[name]
        self.name, self.path = name, build / rel
        self.data = json.loads(self.path.read_text()) if self.path.is_file() else None
        side = self.path.with_name(self.path.name.removesuffix(".json") + ".provenance.json")
        self.provenance = json.loads(side.read_text()) if side.is_file() else None

    @property
    def present(self) -> bool:
        return self.data is not None

    def stamp(self, what: str = "Measured") -> str:
        """One line: when, on which machine, by which command, with which code."""
        p = self.provenance or {}
        date = p.get("date") or datetime.datetime.fromtimestamp(
            self.path.stat().st_mtime, datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC "
                                                                       "(the file's date)")
        m = p.get("machine") or self._own_machine()
        if isinstance(m, dict) and m.get("cpu"):
            mem = f", {m['memory_gib']:g} GiB" if m.get("memory_gib") else ""
            where = f"{m['cpu']} ({m.get('cores', '?')} cores{mem})"
        else:
            where = "a machine it did not record"
        code = ", ".join(x for x in (f"fallgen {p['fallgen']}" if p.get("fallgen") else "",
                                     f"commit {p['commit']}" if p.get("commit") else "") if x)
        return (f"*{what} {date} on {where} by `{p.get('command') or self.command}`"
                + (f" ({code})" if code else "") + ".*\n")

    def _own_machine(self):
        d = self.data or {}
        for part in (d, *(d.get("benchmarks", {}) or {}).values()):
            if isinstance(part, dict) and isinstance(part.get("machine"), dict):
                return part["machine"]
        return None


def _f(x, fmt: str = "{:.2f}") -> str:
    return "-" if x is None else fmt.format(x)


def _table(head: list[str], rows: list[list]) -> str:
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    lines += ["| " + " | ".join(str(c) for c in r) + " |" for r in rows]
    return "\n".join(lines) + "\n"


def _g(x) -> str:
    """A measured value as ``fallgen stats`` prints it, three significant digits."""
    if x is None:
        return "-"
    if isinstance(x, bool):
        return str(x)
    if isinstance(x, float):
        return f"{x:.3g}"
    if isinstance(x, list):
        return " .. ".join(_g(v) for v in x)
    if isinstance(x, dict):
        return ", ".join(f"{k} {v:+.1f}" if isinstance(v, float) else f"{k} {_g(v)}"
                         for k, v in x.items())
    return str(x)


# --- the blocks ----------------------------------------------------------------------------------

def _rows_of_table(data: dict) -> dict[str, tuple[str, tuple | None]]:
    """key -> (label, the paper's SR / SPL / SNA) of the rows ``fallgen table`` made into
    ``data`` (table.json: the trained policies' labels carry their budgets), in the tables'
    order."""
    try:
        sys.path.insert(0, str(REPO / "src"))
        from fallgen.evaluation.table import rows_table1, rows_table2
        from fallgen.evaluation.table_policies import PolicyRun
    except ImportError:  # an older fallgen: the keys stand for themselves
        return {}
    policies = [PolicyRun(t.get("kind", key), Path(t.get("checkpoint", "")),
                          t.get("sha256", ""), t)
                for key, t in data.get("policy_training", {}).items()]
    return {r.key: (r.label, r.paper) for r in [*rows_table1(policies), *rows_table2(policies)]}


def _is_table2(key: str) -> bool:
    """Whether a row of table.json is Table 2's (cross-scene: 'kitchen_to_study',
    'ppo_study_to_kitchen', ...)."""
    return key.endswith(("kitchen_to_study", "study_to_kitchen"))


def _score(s: dict, ci: bool = True) -> list[str]:
    sr = f"{s['success']:.2f}"
    if ci and s.get("ci95", {}).get("success"):
        lo, hi = s["ci95"]["success"]
        sr += f" [{lo:.2f}, {hi:.2f}]"
    return [sr, f"{s['spl']:.2f}", f"{s['sna']:.2f}"]


def _paper(p) -> str:
    return " / ".join(f"{v:.2f}" for v in p) if p else "-"


def results(src: dict[str, Source]) -> str | None:
    """README: the paper-size build's time and the reference agents beside the paper."""
    full, table = src["bench_full"], src["table"]
    if not (full.present or table.present):
        return None
    rows = []
    if full.present:
        f = full.data
        rows.append(["paper-size build from scratch (64 room variants, 8000 episodes), "
                     f"{f.get('workers', '?')} workers",
                     f"**{f['wall_min']['total']:.1f} min**", "~8 h (the original)"])
    else:
        rows.append(["paper-size build from scratch", "not yet measured (`make bench-full`)",
                     "~8 h (the original)"])
    if table.present:
        names = _rows_of_table(table.data)
        order = {k: i for i, k in enumerate(names)}  # the tables' own order, Table 1 first
        done = table.data["results"]
        for key, s in sorted(done.items(), key=lambda kv: order.get(kv[0], len(order))):
            label, paper = names.get(key, (key, None))
            if _is_table2(key):
                label = f"Table 2: {label}"
            rows.append([f"{label}: SR / SPL / SNA (n = {s.get('n', '?')})",
                         " / ".join(_score(s, ci=False)), _paper(paper)])
    else:
        rows.append(["the paper's agents (Table 1, 2)", "not yet measured (`make table`)", ""])
    out = _table(["", "fallgen", "paper / original"], rows) + "\n"
    for s in (full, table):
        out += (s.stamp(f"{'Build' if s is full else 'Agents'}: measured") if s.present
                else NOT_YET.format(command=s.command))
    return out


def schema_columns(src) -> str:
    sys.path.insert(0, str(REPO / "src"))
    from fallgen.dataset.card import target_categories
    from fallgen.dataset.schema import COLUMNS

    rows = []
    for c, (t, u, m) in COLUMNS.items():
        if c == "category":
            m = f"object category (one of {target_categories()} target categories)"
        rows.append([f"`{c}`", t, u or "", m.replace("|", "/")])
    return (_table(["column", "type", "unit", "meaning"], rows)
            + "\n*Generated from `fallgen.dataset.schema` by `make report`.*\n")


def schema_arrays(src) -> str:
    sys.path.insert(0, str(REPO / "src"))
    from fallgen.dataset.schema import ARRAYS

    rows = [[f"`{k}`", s, d, u or "", m.replace("|", "/")]
            for k, (s, d, u, m) in ARRAYS.items()]
    return (_table(["array", "shape", "dtype", "unit", "meaning"], rows)
            + "\n*Generated from `fallgen.dataset.schema` by `make report`.*\n")


def dataset_stats(src) -> str | None:
    s = src["stats"]
    if not s.present:
        return None
    d = s.data
    kinds = sorted({k for v in d["by_split"].values() for k in v})
    rows = [[split, *(by.get(k, 0) for k in kinds), sum(by.values())]
            for split, by in d["by_split"].items()]
    e = d["expert"]
    out = _table(["split", *kinds, "total"], rows) + "\n"
    out += (f"{d['episodes']} episodes in {d['room_variants']} room variants "
            f"({d.get('dropped_episodes', 0)} planned episodes dropped)"
            + (f" from {d['distinct_falls']} distinct falls ({d['episodes_sharing_a_fall']} "
               "episodes share one)" if "distinct_falls" in d else "") + "; "
            f"{len(d['by_category'])} categories, {len(d['by_audio_material'])} audio "
            f"materials, {len(d['by_zone_kind'])} zone kinds. The expert: "
            f"{e['actions']['mean']:.1f} actions on average (median {e['actions']['p50']:.0f}, "
            f"max {e['actions']['max']:.0f}), {e['path_m']['mean']:.2f} m of path; "
            f"{e['episodes_that_look_up_or_down']} episodes look up or down.\n\n")
    return out + s.stamp()


def goals(src) -> str | None:
    s = src["stats"]
    if not s.present:
        return None
    from fallgen.dataset.stats import verdict

    rows = [[name.replace("_", " "), _g(g.get("value")), g.get("bound", ""), verdict(g)]
            for name, g in s.data["goals"].items()]
    return (_table(["goal", "measured", "bound", "met"], rows) + "\n"
            + s.stamp(f"{s.data['episodes']} episodes; measured"))


def energy_by_material(src) -> str | None:
    s = src["stats"]
    if not s.present or not s.data.get("audio_energy_by_material"):
        return None
    rows = [[k, m["episodes"], f"{m['energy_ratio_p50']:.1e}", f"{m['peak_db_spl_p50']:.0f}",
             f"{m['peak_db_spl_max']:.0f}"]
            for k, m in s.data["audio_energy_by_material"].items()]
    return (_table(["audio material", "episodes", "radiated / lost, median",
                    "heard peak dB SPL, median", "max"], rows) + "\n" + s.stamp())


def floors(src) -> str | None:
    s = src["loudness"]
    if not s.present:
        return None
    rows = []
    for f in s.data["floors"]:
        rng = f.get("measured_improvement_db")
        rows.append([f["floor"], f"{f['structure_mm']} mm {f['structure_material']} "
                     f"({f['mass_per_area_kg_m2']:.0f} kg/m2)", f["rating_db"],
                     _f(f.get("bare_rating_db"), "{:.0f}"), _f(f.get("bare_reference_db"),
                                                              "{:.1f}"),
                     _f(f.get("improvement_db"), "{:.0f}"),
                     "-" if not rng else f"{rng[0]:g}-{rng[1]:g}"])
    return (_table(["floor", "structure (m'')", "L_n,w dB", "bare structure L_n,w",
                    "EN ISO 12354-2 bare", "Delta L_w dB", "measured Delta L_w"], rows)
            + "\n" + s.stamp())


def drops(src) -> str | None:
    s = src["loudness"]
    if not s.present:
        return None
    hs = s.data["heights_m"]
    by: dict[tuple, dict] = {}
    for d in s.data["drops"]:
        by.setdefault((f"{d['object']} ({d['mass_g']} g)", d["floor"]), {})[d["drop_m"]] = d
    rows = []
    for (obj, floor), at in by.items():
        cell = lambda key, fmt: " / ".join(fmt.format(at[h][key]) if h in at else "-"  # noqa
                                           for h in hs)
        rows.append([obj, floor, cell("peak_db_spl", "{:.1f}"),
                     cell("leq_125ms_db_spl", "{:.1f}"), cell("radiated_over_lost", "{:.1e}")])
    drop = " / ".join(f"{h:g}" for h in hs)
    return (_table(["object", "floor", f"peak dB SPL, {drop} m drop", "Leq 125 ms dB SPL",
                    "radiated / lost"], rows) + "\n" + s.stamp())


def rt60(src) -> str | None:
    s = src["stats"]
    if not s.present or not s.data.get("room_rt60_s"):
        return None
    r = s.data["room_rt60_s"]
    rows = [[f"{k} Hz", f"{b['min']:.2f}", f"{b['p50']:.2f}", f"{b['max']:.2f}"]
            for k, b in r["by_band"].items()]
    out = _table(["octave band", "min, s", "median, s", "max, s"], rows) + "\n"
    g = s.data["goals"].get("rt60_mid", {})
    if g.get("value") and g.get("traced"):
        out += (f"At 500 Hz-1 kHz the model gives {_g(g['model'])} s over the "
                f"{r['variants']} variants, the ray tracer {_g(g['value'])} s "
                f"({g['traced']} variants traced as the build has them, `bench/rays_table.py`)"
                f"; {g['outside']} variants outside 0.3-0.9 s"
                + (f": {', '.join(g['variants_outside'])}" if g["variants_outside"] else "")
                + ".\n\n")
    elif g.get("value"):
        out += (f"At 500 Hz-1 kHz the model gives {_g(g['model'])} s over the "
                f"{r['variants']} variants; times the ray tracer's ratio to it "
                f"({_g(g['rays_over_model'])}): {_g(g['value'])} s (range {_g(g['range'])}); "
                f"{g['outside']} variants outside 0.3-0.9 s.\n\n")
    return out + s.stamp(f"Over the {r['variants']} room variants of the build; measured")


def appearance(src) -> str | None:
    s = src["bench"]
    a = (s.data or {}).get("benchmarks", {}).get("appearance") if s.present else None
    if not a:
        return None
    rows = [[tag, f"{a[tag]['detail_mean']:.3f}", f"{a[tag]['detail_p10']:.3f}",
             a[tag]["rgb_ms_per_view"], a[tag]["depth_seg_ms_per_view"],
             a[tag]["scene_and_camera_ms"]]
            for tag in ("flat", "textured", "randomised") if tag in a]
    return (_table(["views", "detail share, mean", "p10", "RGB ms / view",
                    "depth + segmentation ms / view", "scene + camera ms"], rows)
            + f"\n{a.get('views', '?')} random step-0 poses over the room variants.\n\n"
            + s.stamp())


def _table_rows(src, keys: Callable[[str], bool]) -> tuple[list, Source] | None:
    s = src["table"]
    if not s.present:
        return None
    names = _rows_of_table(s.data)
    order = {k: i for i, k in enumerate(names)}  # the tables' own order
    rows = []
    for key, r in sorted(s.data["results"].items(),
                         key=lambda kv: order.get(kv[0], len(order))):
        if keys(key):
            label, paper = names.get(key, (key, None))
            rows.append([label, *_score(r), r.get("n", "?"), _paper(paper)])
    return rows, s


def table1(src) -> str | None:
    got = _table_rows(src, lambda k: not _is_table2(k))
    if got is None:
        return None
    rows, s = got
    return (_table(["Table 1 (test split)", "SR [95 % CI]", "SPL", "SNA", "episodes",
                    "paper SR / SPL / SNA"], rows) + "\n" + s.stamp())


def table2(src) -> str | None:
    got = _table_rows(src, _is_table2)
    if got is None or not got[0]:
        return None
    rows, s = got
    return (_table(["Table 2 (cross-scene)", "SR [95 % CI]", "SPL", "SNA", "episodes",
                    "paper SR / SPL / SNA"], rows) + "\n" + s.stamp())


#: (label, key, format) of the audio module's scores
AUDIO_SCORES = (("category, top-1", "category_top1", "{:.3f}"),
                ("category, top-5", "category_top5", "{:.3f}"),
                ("audio material, top-1", "material_top1", "{:.3f}"),
                ("azimuth, median error", "azimuth_median_error_deg", "{:.1f} deg"),
                ("lateral angle (front and back folded), median error",
                 "lateral_median_error_deg", "{:.1f} deg"),
                ("front/back confusions (sources > 15 deg off the ears' axis)",
                 "front_back_confusion_rate", "{:.3f}"),
                ("position, median error", "position_median_error_m", "{:.2f} m"),
                ("distance, rank correlation", "distance_rank_correlation", "{:.3f}"),
                ("distance, rank correlation within a room (mean over room variants)",
                 "distance_rank_correlation_within_room", "{:.3f}"),
                ("distance told the room as the prior is, rank correlation",
                 "distance_rank_correlation_told_room", "{:.3f}"),
                ("distance told the room as the prior is, rank correlation within a room",
                 "distance_rank_correlation_within_room_told_room", "{:.3f}"))


def audio_module(src) -> str | None:
    """The auditory perception module on Table 1's test episodes, beside a prior that does
    not listen and chance."""
    s = src["table"]
    a = (s.data or {}).get("audio", {}).get("all_on_test") if s.present else None
    if not a:
        return None
    fmt = lambda d, k, f: "-" if d.get(k) is None else f.format(d[k])  # noqa: E731
    rows = [[label, f"**{fmt(a, key, f)}**", fmt(a.get("prior", {}), key, f),
             fmt(a.get("chance", {}), key, f)] for label, key, f in AUDIO_SCORES
            if a.get(key) is not None]  # a score an older table.json does not have
    return (_table(["from the step-0 clip", "model", "prior (no audio)", "chance"], rows)
            + f"\n{a.get('episodes', '?')} test episodes.\n\n" + s.stamp())


def hrtf_heads(src) -> str | None:
    """The audio module trained and scored on two builds that differ only in the head."""
    s = src["hrtf"]
    d = s.data if s.present else None
    if not d or not d.get("heads"):
        return None
    heads = d["heads"]
    kinds = sorted({k for h in heads.values() for k in h.get("by_room_kind", {})})
    rows = []
    for label, key, f in (("azimuth, median error", "azimuth_median_error_deg", "{:.1f} deg"),
                          ("lateral angle, median error", "lateral_median_error_deg",
                           "{:.1f} deg"),
                          ("front/back confusion rate", "front_back_confusion_rate", "{:.3f}")):
        for part in (None, *kinds):
            cells = []
            for h in ("sadie_ku100", "sphere"):
                v = heads.get(h, {})
                v = v if part is None else v.get("by_room_kind", {}).get(part, {})
                cells.append(_f(v.get(key), f))
            prior = next(iter(heads.values())).get("prior", {}) if part is None else {}
            rows.append([label + (f", {part}" if part else ""), *cells,
                         _f(prior.get(key), f)])
    diff = d.get("sadie_minus_sphere", {})
    lines = []
    for key, name, f in (("azimuth_median_error_deg", "median azimuth error", "{:+.1f} deg"),
                         ("front_back_confusion_rate", "front/back confusion rate",
                          "{:+.3f}")):
        x = diff.get(key)
        if x:
            lo, hi = x["ci95"]
            lines.append(f"{name} {f.format(x['difference'])} "
                         f"[{f.format(lo)}, {f.format(hi)}]")
    eps = d.get("episodes", {})
    return (_table(["the audio module, on the same test episodes", "SADIE KU100 (measured)",
                    "spherical head", "room-centre prior (no audio)"], rows)
            + f"\n{d.get('common_test_episodes', '?')} test episodes in both builds "
              f"({eps.get('train', '?')} train episodes each, config `{d.get('config', '?')}`, "
              f"seed {d.get('seed', '?')}). Measured minus sphere, paired, with 95 % bootstrap "
              "intervals: " + "; ".join(lines) + ".\n\n" + s.stamp())


def full_build(src) -> str | None:
    s = src["bench_full"]
    if not s.present:
        return None
    f = s.data
    w, g = f["wall_min"], f.get("generation", {})
    rows = [["wall time (rehearse + generate)",
             f"**{w['total']:.1f} min** ({w['rehearse']:.1f} + {w['generate']:.1f})",
             f"{f.get('goal_min', 10):g} min"],
            ["against the original's ~8 h", f"{f.get('speedup_vs_original_8h', '-')}x", ""],
            ["CPU time (all processes)", f"{f['cpu_s']:.0f} s ({f['cpu_use']:.2f} cores busy)",
             ""],
            ["peak memory of a worker", f"{f.get('peak_worker_mb', '-')} MB", "< 1024 MB"],
            ["episodes, shards", f"{g.get('episodes', '-')}, {g.get('shards', '-')}", ""],
            ["disk", f"{f['bytes'] / 1e9:.2f} GB, {f['bytes_per_episode'] / 1e3:.0f} kB per "
             "episode", ""],
            ["modal models solved (0: cache warm)", f.get("modal_models_solved", "-"), ""],
            ["valid (`fallgen validate`)", "yes" if f.get("valid") else "NO", ""],
            ["files' fingerprint", f"`{str(f.get('fingerprint', '-'))[:16]}`", ""]]
    if "one_worker" in f:
        o = f["one_worker"]
        rows.append(["generation, workers against 1",
                     f"{o.get('speedup_of_workers', '-')}x, same bytes: "
                     f"{'yes' if o.get('same_bytes') else 'NO'}", ">= 1.8x with 2"])
    stages = g.get("stage_s") or {}
    total = sum(stages.values())
    if total:
        rows.append(["generation CPU by stage", ", ".join(
            f"{k} {v / total:.0%}" for k, v in stages.items()), ""])
    return _table(["", "measured", "goal"], rows) + "\n" + s.stamp()


def benches(src) -> str | None:
    s = src["bench"]
    if not s.present:
        return None
    b = s.data.get("benchmarks", {})
    rows = []
    if "rehearse" in b:
        r = b["rehearse"]
        rows.append(["rehearsal, one core", f"{r['trials_per_s']} trials/s "
                     f"({r['kept_per_s']} kept/s)", f"{r['variant']}"])
    if "generate" in b:
        gb = b["generate"]
        rows.append(["one episode, one core, ms by stage", ", ".join(
            f"{k} {v}" for k, v in gb["ms_per_episode"].items()), gb.get("variant", "")])
    if "build" in b:
        bb = b["build"]
        x = bb["full_build_extrapolated"]
        rows.append(["paper-size build, extrapolated from a slice", f"{x['total_min']} min",
                     f"{bb['generate']['speedup']}x with {bb['workers']} workers; same bytes: "
                     f"{bb['generate']['same_bytes']}"])
    if "impact" in b:
        i = b["impact"]
        peer = (f"PyImpact: {i['speedup_vs_pyimpact_new_pair']}x per impact, "
                f"{i['speedup_vs_pyimpact_audio_second']}x per second of audio"
                if "speedup_vs_pyimpact_new_pair" in i else "PyImpact not run")
        rows.append(["one impact, object + floor, 2 s", f"{i['ours_ms_median']} ms", peer])
    if "room" in b:
        r = b["room"]
        peer = (f"pyroomacoustics: {r['speedup_omni_order6']}x (omni), "
                f"{r.get('speedup_binaural_order6_early', '-')}x (binaural early)"
                if "speedup_omni_order6" in r else "pyroomacoustics not run")
        rows.append(["image sources, order 6: omni / binaural early / binaural 2 s",
                     f"{r['omni_order6_ms']} / {r['binaural_order6_early_ms']} / "
                     f"{r['binaural_order6_2s_ms']} ms", peer])
    if "env" in b:
        e = b["env"]
        v = e["vector"]
        rows.append(["environment steps/s, rgb + depth (no view cache)",
                     f"{e['rgb_depth']['steps_per_s']} ({e['rgb_depth_no_cache']['steps_per_s']})",
                     f">= {e.get('goal_steps_per_s', 100)}"])
        rows.append(["make_vec, 2 workers against 1 (send/recv)",
                     f"{v['two_workers_steps_per_s']} / {v['one_worker_steps_per_s']}: "
                     f"{v['speedup']}x", f">= {v.get('goal_speedup', 1.8)}x"])
        rows.append(["peak memory of an environment worker", f"{v['peak_worker_mb']:.0f} MB",
                     "< 1024 MB"])
    if not rows:
        return None
    return _table(["what", "measured", "beside"], rows) + "\n" + s.stamp()


def vision_module(src) -> str | None:
    """The visual perception module on Table 1's test episodes' frames, and what its
    training took."""
    s = src["table"]
    v = (s.data or {}).get("vision") if s.present else None
    if not v:
        return None
    t = s.data.get("vision_training", {})
    f3 = "{:.3f}".format
    rows = [["mIoU over the 31 target categories", f3(v["miou"]), f"{v['frames']} frames"],
            ["found, the category asked for (>= 4 px where it shows >= 50 px within 2 m)",
             f"**{f3(v['found_asked'])}**", f"{v['found_frames']} frames"],
            ["false alarms, the category asked for (>= 4 px where it is not visible)",
             f"**{f3(v['false_alarms_asked'])}**", f"{v['false_alarm_frames']} frames"],
            ["found, the best of all targets", f3(v["found"]), f"{v['found_frames']} frames"],
            ["false alarms, the best of all targets", f3(v["false_alarms"]),
             f"{v['false_alarm_frames']} frames"],
            ["inference, one thread", f"{v['inference_ms_per_frame_1_thread']:.1f} ms a frame",
             "300 x 300 RGB-D"]]
    if t:
        rows.append(["training", f"{(t.get('frames_seconds') or 0) / 60:.1f} min drawing "
                     f"{t.get('train_frames')} frames of {t.get('train_episodes')} train "
                     f"episodes, {(t.get('train_seconds') or 0) / 60:.1f} min training",
                     f"on {t.get('device', 'cpu')}" + (
                         f", {t['settings']['epochs']} epochs"
                         if (t.get("settings") or {}).get("epochs") else "")])
    return (_table(["the visual module", "measured", "over"], rows)
            + f"\n{v['episodes']} test episodes.\n\n" + s.stamp())


#: block name -> renderer (None: nothing to render from; the block is kept)
RENDERERS: dict[str, Callable[[dict], str | None]] = {
    "results": results, "schema-columns": schema_columns, "schema-arrays": schema_arrays,
    "dataset-stats": dataset_stats, "goals": goals, "energy-by-material": energy_by_material,
    "floors": floors, "drops": drops, "rt60": rt60, "appearance": appearance,
    "table1": table1, "table2": table2, "audio-module": audio_module,
    "vision-module": vision_module,
    "full-build": full_build, "benches": benches, "hrtf-heads": hrtf_heads,
}


def render_file(path: Path, sources: dict[str, Source], log: Callable[[str], None]) -> bool:
    """Rewrite ``path``'s generated blocks; True if its text changed."""
    text = path.read_text()

    def one(m: re.Match) -> str:
        name = m["name"]
        if name not in RENDERERS:
            raise SystemExit(f"{path}: unknown generated block {name!r} "
                             f"(known: {', '.join(RENDERERS)})")
        body = RENDERERS[name](sources)
        if body is None:
            log(f"{path.name}: {name}: kept (its source is absent: "
                + ", ".join(f"{s.path} from `{s.command}`" for s in sources.values()
                            if not s.present and s.name in _needs(name)) + ")")
            return m.group(0)
        log(f"{path.name}: {name}: written")
        return m["open"] + body + m["close"]

    new = BLOCK.sub(one, text)
    opened = len(re.findall(r"<!-- generated: ", text))
    if opened != len(BLOCK.findall(text)):
        raise SystemExit(f"{path}: a generated block without its end marker")
    if new != text:
        path.write_text(new)
    return new != text


def _needs(block: str) -> tuple[str, ...]:
    return {"results": ("bench_full", "table"), "dataset-stats": ("stats",),
            "goals": ("stats",), "energy-by-material": ("stats",), "rt60": ("stats",),
            "floors": ("loudness",), "drops": ("loudness",), "appearance": ("bench",),
            "benches": ("bench",), "table1": ("table",), "table2": ("table",),
            "audio-module": ("table",), "vision-module": ("table",),
            "full-build": ("bench_full",), "hrtf-heads": ("hrtf",)}.get(block, ())


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--build", type=Path, default=REPO / "build",
                    help="where the result files are (default: build/)")
    ap.add_argument("--root", type=Path, default=REPO,
                    help="the documentation's root: README.md and docs/*.md under it")
    a = ap.parse_args(argv)
    sources = {name: Source(name, a.build) for name in SOURCES}
    files = [a.root / "README.md", *sorted((a.root / "docs").glob("*.md"))]
    changed = [p for p in files if p.is_file() and render_file(p, sources, print)]
    print(f"{len(changed)} file(s) changed" + (f": {', '.join(p.name for p in changed)}"
                                               if changed else ""))


if __name__ == "__main__":
    main()
