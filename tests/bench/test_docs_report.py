"""bench/docs_report.py (``make report``) on small fake result files: every generated block is
written from its JSON with the date, the machine and the command that made it; a block whose
JSON is absent keeps what it says and the report says so; a block it does not know, or
without its end marker, stops it; a second run changes nothing. And the repository's own
README.md and docs/ hold only blocks it knows, each closed."""

from __future__ import annotations

import json
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(REPO / "bench"))

import docs_report  # noqa: E402
import provenance  # noqa: E402

MACHINE = {"cpu": "Test CPU 9000", "cores": 3, "memory_gib": 7.5, "system": "Linux x86_64",
           "python": "3.11.0"}


def _write(build: Path, rel: str, data: dict, command: str, date: str) -> None:
    path = build / rel
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(data))
    provenance.sidecar(path).write_text(json.dumps(
        {"file": str(path), "command": command, "date": date, "machine": MACHINE,
         "fallgen": "9.9.9", "commit": "abc1234567"}))


STATS = {
    "episodes": 8000, "room_variants": 64, "dropped_episodes": 3,
    "by_split": {"train": {"kitchen": 3000, "study": 3000},
                 "validation": {"kitchen": 500, "study": 500},
                 "test": {"kitchen": 500, "study": 500}},
    "by_category": {"cup": 5000, "fork": 3000}, "by_audio_material": {"glass": 8000},
    "by_zone_kind": {"floor": 8000},
    "expert": {"actions": {"mean": 11.25, "p50": 10.0, "max": 41.0},
               "path_m": {"mean": 1.5}, "episodes_that_look_up_or_down": 123},
    "audio_energy_by_material": {"glass": {"episodes": 8000, "energy_ratio_p50": 2.5e-5,
                                           "peak_db_spl_p50": 88.4, "peak_db_spl_max": 121.0}},
    "room_rt60_s": {"variants": 64, "by_band": {"500": {"min": 0.31, "p50": 0.57, "max": 0.88}}},
    "goals": {
        "fall_height": {"value": 0.3021, "short": 0, "bound": "every fall >= 0.3 m",
                        "ok": True},
        "peak_db_spl_range": {"value": [39.9, 131.0], "bound": "35..125", "ok": False},
        "rt60_mid": {"model": [0.3, 0.7], "value": [0.32, 0.86], "range": [0.31, 1.38],
                     "rays_over_model": [1.04, 1.23, 1.97], "outside": 0,
                     "bound": "0.3..0.9 s", "ok": None},
    },
}
TABLE = {
    "selection": {"episodes": 300},
    "results": {
        "random": {"success": 0.0123, "spl": 0.01, "sna": 0.009, "n": 300,
                   "ci95": {"success": [0.003, 0.027]}},
        "modular_seg_obj_loc": {"success": 0.9412, "spl": 0.851, "sna": 0.793, "n": 300,
                                "ci95": {"success": [0.91, 0.96]}},
        "kitchen_to_study": {"success": 0.3311, "spl": 0.24, "sna": 0.22, "n": 200,
                             "ci95": {"success": [0.26, 0.39]}},
    },
    "audio": {"all_on_test": {
        "episodes": 300, "category_top1": 0.574, "category_top5": 0.819, "material_top1": 0.632,
        "azimuth_median_error_deg": 18.24, "lateral_median_error_deg": 7.9,
        "position_median_error_m": 1.53, "distance_rank_correlation": 0.456,
        "chance": {"category_top1": 0.032, "azimuth_median_error_deg": 90.0},
        "prior": {"category_top1": 0.03, "azimuth_median_error_deg": 28.8}}},
    "vision": {"episodes": 300, "frames": 1800, "miou": 0.0467, "found": 0.422,
               "found_frames": 218, "false_alarms": 0.0563, "false_alarm_frames": 551,
               "found_asked": 0.7798, "false_alarms_asked": 0.0581,
               "inference_ms_per_frame_1_thread": 11.8},
    "vision_training": {"train_frames": 24000, "train_episodes": 4000, "frames_seconds": 720.0,
                        "train_seconds": 1464.0, "device": "cpu", "settings": {"epochs": 4}},
    "timings_s": {"total": 2000.0},
}
FULL = {"workers": 2, "wall_min": {"total": 14.321, "rehearse": 3.5, "generate": 10.8},
        "goal_min": 15.0, "speedup_vs_original_8h": 33.5, "cpu_s": 1650.0, "cpu_use": 1.92,
        "peak_worker_mb": 940, "bytes": 6.1e9, "bytes_per_episode": 762000,
        "modal_models_solved": 0, "valid": True, "fingerprint": "04556ca5deadbeef0000",
        "generation": {"episodes": 8000, "shards": 32,
                       "stage_s": {"audio": 650.0, "render": 140.0}},
        "one_worker": {"speedup_of_workers": 1.97, "same_bytes": True},
        "machine": {"cpu": "Other CPU", "cores": 2}}
LOUDNESS = {
    "heights_m": [0.75, 1.5],
    "floors": [{"floor": "ceramic_tile", "structure_mm": 150, "structure_material": "stone",
                "mass_per_area_kg_m2": 405.0, "rating_db": 72, "bare_rating_db": 72,
                "bare_reference_db": 72.74, "improvement_db": 0.0,
                "measured_improvement_db": None}],
    "drops": [{"object": "ceramic mug", "mass_g": 287, "floor": "ceramic tile",
               "room_variant": "kitchen_galley-l1-m2", "drop_m": h, "peak_db_spl": p,
               "leq_125ms_db_spl": p - 25, "radiated_over_lost": 8.8e-4}
              for h, p in ((0.75, 115.9), (1.5, 119.4))],
}
BENCH = {"headline": {}, "benchmarks": {
    "appearance": {"views": 64, "flat": {"detail_mean": 0.114, "detail_p10": 0.038,
                                         "rgb_ms_per_view": 2.5, "depth_seg_ms_per_view": 3.0,
                                         "scene_and_camera_ms": 4.1},
                   "textured": {"detail_mean": 0.498, "detail_p10": 0.317,
                                "rgb_ms_per_view": 11.3, "depth_seg_ms_per_view": 3.4,
                                "scene_and_camera_ms": 18.8}},
    "env": {"rgb_depth": {"steps_per_s": 137.2}, "rgb_depth_no_cache": {"steps_per_s": 81.0},
            "goal_steps_per_s": 100,
            "vector": {"one_worker_steps_per_s": 169.0, "two_workers_steps_per_s": 311.0,
                       "speedup": 1.84, "goal_speedup": 1.8, "peak_worker_mb": 501.0}},
    "impact": {"ours_ms_median": 2.85, "speedup_vs_pyimpact_new_pair": 0.49,
               "speedup_vs_pyimpact_audio_second": 10.0},
}}

HRTF = {"config": "configs/full.toml", "episodes": {"train": 1500, "validation": 100,
                                                    "test": 500},
        "seed": 0, "common_test_episodes": 498,
        "heads": {"sadie_ku100": {"azimuth_median_error_deg": 11.04,
                                  "lateral_median_error_deg": 6.5,
                                  "front_back_confusion_rate": 0.1234,
                                  "prior": {"front_back_confusion_rate": 0.19},
                                  "by_room_kind": {"kitchen": {"front_back_confusion_rate": 0.1}}},
                  "sphere": {"azimuth_median_error_deg": 19.0, "lateral_median_error_deg": 6.9,
                             "front_back_confusion_rate": 0.3456,
                             "by_room_kind": {"kitchen": {"front_back_confusion_rate": 0.3}}}},
        "sadie_minus_sphere": {
            "azimuth_median_error_deg": {"difference": -7.96, "ci95": [-9.5, -6.1]},
            "front_back_confusion_rate": {"difference": -0.2222, "ci95": [-0.28, -0.17]}}}

DOC = """# A page

Text before.

<!-- generated: {name} (make report writes this) -->
old words
<!-- end: {name} -->

Text after.
"""


@pytest.fixture
def tree(tmp_path):
    """(root with README.md and docs/, build directory): one page per block the generator
    knows."""
    root, build = tmp_path / "root", tmp_path / "build"
    (root / "docs").mkdir(parents=True)
    build.mkdir()
    (root / "README.md").write_text(DOC.format(name="results"))
    for name in docs_report.RENDERERS:
        if name != "results":
            (root / "docs" / f"{name}.md").write_text(DOC.format(name=name))
    return root, build


def _block(root: Path, name: str) -> str:
    path = root / ("README.md" if name == "results" else f"docs/{name}.md")
    m = docs_report.BLOCK.search(path.read_text())
    assert m and m["name"] == name
    return m["body"]


def _all_sources(build: Path) -> None:
    _write(build, "full-stats.json", STATS, "make dataset", "2026-11-27 10:00 UTC")
    _write(build, "table/table.json", TABLE, "make table TABLE_EPISODES=300",
           "2026-11-27 11:00 UTC")
    _write(build, "bench-full.json", FULL, "make bench-full", "2026-11-27 09:00 UTC")
    _write(build, "loudness.json", LOUDNESS, "make loudness", "2026-11-27 08:00 UTC")
    _write(build, "bench.json", BENCH, "make bench", "2026-11-27 07:00 UTC")
    _write(build, "hrtf.json", HRTF, "make hrtf", "2026-11-27 06:00 UTC")


def test_every_block_is_written_from_its_json_with_date_machine_and_command(tree, capsys):
    root, build = tree
    _all_sources(build)
    docs_report.main(["--build", str(build), "--root", str(root)])
    stamp = "on Test CPU 9000 (3 cores, 7.5 GiB)"
    for name in docs_report.RENDERERS:
        body = _block(root, name)
        assert "old words" not in body, name
        if not name.startswith("schema"):
            assert stamp in body and "fallgen 9.9.9, commit abc1234567" in body, name
    results = _block(root, "results")
    assert "**14.3 min**" in results and "2026-11-27 09:00 UTC" in results
    assert "`make bench-full`" in results and "`make table TABLE_EPISODES=300`" in results
    assert "0.94 / 0.85 / 0.79" in results and "0.93 / 0.83 / 0.80" in results  # the paper's
    assert "| 0.94 [0.91, 0.96] | 0.85 | 0.79 | 300 |" in _block(root, "table1")
    assert "kitchen_to_study" not in _block(root, "table1")
    audio = _block(root, "audio-module")
    assert "| azimuth, median error | **18.2 deg** | 28.8 deg | 90.0 deg |" in audio
    assert "| distance, rank correlation | **0.456** | - | - |" in audio
    vision = _block(root, "vision-module")
    assert "| mIoU over the 31 target categories | 0.047 | 1800 frames |" in vision
    assert "| **0.780** | 218 frames |" in vision and "| **0.058** | 551 frames |" in vision
    assert "11.8 ms a frame" in vision and "12.0 min drawing 24000 frames of 4000 train " \
        "episodes, 24.4 min training | on cpu, 4 epochs |" in vision
    assert "| 0.33 [0.26, 0.39] | 0.24 | 0.22 | 200 | 0.34 / 0.23 / 0.20 |" in \
        _block(root, "table2")
    goals = _block(root, "goals")
    assert "| fall height | 0.302 | every fall >= 0.3 m | yes |" in goals
    assert "| peak db spl range | 39.9 .. 131 | 35..125 | NO |" in goals
    assert "| 500 Hz | 0.31 | 0.57 | 0.88 |" in _block(root, "rt60")
    assert "| ceramic mug (287 g) | ceramic tile | 115.9 / 119.4 | 90.9 / 94.4 | " \
           "8.8e-04 / 8.8e-04 |" in _block(root, "drops")
    assert "| ceramic_tile | 150 mm stone (405 kg/m2) | 72 | 72 | 72.7 | 0 | - |" in \
        _block(root, "floors")
    assert "| train | 3000 | 3000 | 6000 |" in _block(root, "dataset-stats")
    assert "| glass | 8000 | 2.5e-05 | 88 | 121 |" in _block(root, "energy-by-material")
    assert "| textured | 0.498 | 0.317 | 11.3 | 3.4 | 18.8 |" in _block(root, "appearance")
    assert "1.97x, same bytes: yes" in _block(root, "full-build")
    heads = _block(root, "hrtf-heads")
    assert "| front/back confusion rate | 0.123 | 0.346 | 0.190 |" in heads
    assert "| front/back confusion rate, kitchen | 0.100 | 0.300 | - |" in heads
    assert "| azimuth, median error | 11.0 deg | 19.0 deg | - |" in heads
    assert "front/back confusion rate -0.222 [-0.280, -0.170]" in heads
    assert "498 test episodes in both builds (1500 train episodes each" in heads
    assert "311.0 / 169.0: 1.84x" in _block(root, "benches")
    assert "`fallgen.dataset.schema`" in _block(root, "schema-columns")
    assert "| `episode_id` | int64 |" in _block(root, "schema-columns")
    assert "| `audio` | (N, 2, T) | float32 |" in _block(root, "schema-arrays")
    # the text around the blocks is untouched, and a second run changes nothing
    text = (root / "README.md").read_text()
    assert text.startswith("# A page\n\nText before.\n") and text.endswith("Text after.\n")
    before = {p: p.read_text() for p in [root / "README.md", *(root / "docs").glob("*.md")]}
    capsys.readouterr()
    docs_report.main(["--build", str(build), "--root", str(root)])
    assert "0 file(s) changed" in capsys.readouterr().out
    assert before == {p: p.read_text() for p in before}


def test_a_block_without_its_json_is_kept_and_said(tree, capsys):
    root, build = tree
    _write(build, "loudness.json", LOUDNESS, "make loudness", "2026-11-27 08:00 UTC")
    docs_report.main(["--build", str(build), "--root", str(root)])
    out = capsys.readouterr().out
    assert "old words" in _block(root, "goals") and "old words" in _block(root, "table1")
    assert "old words" not in _block(root, "floors")
    assert re.search(r"goals\.md: goals: kept \(its source is absent: \S*full-stats\.json from "
                     r"`make dataset`\)", out)
    assert "floors.md: floors: written" in out


def test_a_partial_results_table_says_what_is_not_yet_measured(tree):
    root, build = tree
    _write(build, "bench-full.json", FULL, "make bench-full", "2026-11-27 09:00 UTC")
    docs_report.main(["--build", str(build), "--root", str(root)])
    body = _block(root, "results")
    assert "**14.3 min**" in body
    assert "not yet measured (`make table`)" in body
    assert "*Not yet measured: run `make table`, then `make report`.*" in body


def test_without_a_provenance_file_the_jsons_own_machine_and_the_files_date(tree):
    root, build = tree
    (build / "bench-full.json").write_text(json.dumps(FULL))
    docs_report.main(["--build", str(build), "--root", str(root)])
    body = _block(root, "full-build")
    assert "on Other CPU (2 cores) by `make bench-full`" in body
    assert "(the file's date)" in body


@pytest.mark.parametrize("text, words", [
    (DOC.format(name="no-such-block"), "unknown generated block 'no-such-block'"),
    ("<!-- generated: goals (make report) -->\nold\n", "without its end marker"),
])
def test_a_block_it_cannot_write_stops_it(tree, text, words):
    root, build = tree
    (root / "docs" / "zz.md").write_text(text)
    with pytest.raises(SystemExit, match=re.escape(words)):
        docs_report.main(["--build", str(build), "--root", str(root)])


def test_provenance_records_the_machine_and_the_command(tmp_path):
    f = tmp_path / "x.json"
    f.write_text("{}")
    done = subprocess.run([sys.executable, str(REPO / "bench" / "provenance.py"), str(f),
                           "make", "loudness"], capture_output=True, text=True, check=True)
    side = tmp_path / "x.provenance.json"
    assert str(side) in done.stdout
    p = json.loads(side.read_text())
    assert p["command"] == "make loudness" and p["machine"]["cores"] >= 1
    assert p["machine"]["cpu"] and re.fullmatch(r"\d{4}-\d\d-\d\d \d\d:\d\d UTC", p["date"])
    import fallgen

    assert p["fallgen"] == fallgen.__version__


def test_the_repositorys_documentation_holds_only_blocks_it_knows(tmp_path):
    """README.md and docs/*.md as they are: every block known and closed, and a run with no
    result files changes nothing but the blocks made from the code (the schema's)."""
    root = tmp_path / "root"
    (root / "docs").mkdir(parents=True)
    shutil.copy(REPO / "README.md", root / "README.md")
    for p in (REPO / "docs").glob("*.md"):
        shutil.copy(p, root / "docs" / p.name)
    names = {m["name"] for p in [root / "README.md", *(root / "docs").glob("*.md")]
             for m in docs_report.BLOCK.finditer(p.read_text())}
    assert names == set(docs_report.RENDERERS)
    docs_report.main(["--build", str(tmp_path / "empty"), "--root", str(root)])
    for p in [REPO / "README.md", *(REPO / "docs").glob("*.md")]:
        mine = root / ("README.md" if p.name == "README.md" and p.parent == REPO
                       else f"docs/{p.name}")
        assert mine.read_text() == p.read_text(), p.name
