"""The command line as a user meets it: help everywhere, tables, pictures, one-line errors."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from fallgen.cli import main

COMMANDS = [[], ["rooms"], ["rooms", "list"], ["rooms", "check"], ["rooms", "show"],
            ["rooms", "export"], ["rooms", "acoustics"], ["objects"], ["objects", "list"],
            ["objects", "show"], ["materials"],
            ["materials", "list"], ["rehearse"], ["assets"], ["assets", "modes"], ["sounds"]]


def run(capsys, *args: str) -> tuple[int, str, str]:
    with pytest.raises(SystemExit) as e:
        main(list(args))
    out, err = capsys.readouterr()
    return e.value.code, out, err


@pytest.mark.parametrize("cmd", COMMANDS, ids=lambda c: " ".join(c) or "fallgen")
def test_help_everywhere(capsys, cmd):
    code, out, _ = run(capsys, *cmd, "--help")
    assert code == 0
    assert "Usage" in out


def test_version(capsys):
    code, out, _ = run(capsys, "--version")
    assert code == 0 and "fallgen" in out and "mujoco 4.0.0" in out


def test_rooms_list(capsys):
    code, out, _ = run(capsys, "rooms", "list")
    assert code == 0
    assert "64 variants: 32 kitchen, 32 study" in out


def test_rooms_show_and_export(capsys, tmp_path):
    png = tmp_path / "room.png"
    code, _, err = run(capsys, "rooms", "show", "kitchen_galley-l1-m1", "-o", str(png))
    assert code == 0, err
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    xml = tmp_path / "room.xml"
    code, _, err = run(capsys, "rooms", "export", "kitchen_galley-l1-m1", "-o", str(xml))
    assert code == 0, err
    import mujoco

    assert mujoco.MjModel.from_xml_path(str(xml)).ngeom > 20
    code, _, err = run(capsys, "rooms", "show", "kitchen_galley-*", "-o", str(tmp_path / "all"))
    assert code == 0, err
    assert len(list((tmp_path / "all").glob("*.png"))) == 8


def test_rooms_acoustics(capsys, tmp_path):
    """The furnished room's RT60 per octave band (7 values, 125 Hz-8 kHz) beside the T30 of a
    rendered response, as JSON and as a table, and the decay curves' PNG."""
    import json

    png = tmp_path / "decay.png"
    code, out, err = run(capsys, "rooms", "acoustics", "study_office-l1-m1", "--json", "-o",
                         str(png))
    assert code == 0, err
    r = json.loads(out)
    assert r["variant"] == "study_office-l1-m1" and len(r["rt60_s"]) == 7
    # what it prints is the furnished room model's own
    from fallgen.audio.room import RoomAcoustics
    from fallgen.world.library import load_world

    world = load_world()
    v = world.variant("study_office-l1-m1")
    room = RoomAcoustics.furnished(v, world.materials)
    assert np.allclose(r["rt60_s"], room.rt60(), atol=1e-3)
    # furniture adds surface and takes volume: the mean free path is below the bare
    # shoebox's 4 V / S (Kosten), and not below half of it in a furnished study
    lx, ly, lz = v.size_m
    bare = 4 * lx * ly * lz / (2 * (lx * ly + lx * lz + ly * lz))
    assert 0.5 * bare < r["mean_free_path_m"] < bare and r["furniture_parts"] > 10
    # it decays as modelled (at 125 Hz the octave also sees 250 Hz's longer decay)
    assert np.allclose(r["t30_s"][2:5], r["rt60_s"][2:5], rtol=0.15)
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    code, out, err = run(capsys, "rooms", "acoustics", "study_office-l1-m1")
    assert code == 0, err
    assert "RT60 model" in out and "T30 rendered" in out and "mean free path" in out
    code, out, err = run(capsys, "rooms", "acoustics", "study_office-l1-*")  # a row each
    assert code == 0, err
    assert "2 variants" in out and "study_office-l1-m1" in out and "study_office-l1-m2" in out


def test_unknown_room(capsys, tmp_path):
    out = tmp_path / "x.png"
    code, _, err = run(capsys, "rooms", "show", "no_such_room", "-o", str(out))
    assert code == 2
    assert err.count("\n") == 1 and "no room variant matches" in err
    assert not out.exists()


def test_objects_and_materials_list(capsys):
    code, out, _ = run(capsys, "objects", "list")
    assert code == 0 and "31 target categories" in out
    code, out, _ = run(capsys, "materials", "list")
    assert code == 0 and "plastic_soft_foam" in out and "8000" in out


# --- malformed data files: one line naming file and field, exit code 2, nothing written --------

def _sub(path: Path, old: str, new: str, count: int = 1) -> None:
    text = path.read_text()
    assert old in text, f"{old!r} not in {path}"
    path.write_text(text.replace(old, new, count))


def _first_furniture_size(text: str) -> str:
    return re.search(r"size = \[[^\]]+\]", text.split("furniture = [", 1)[1]).group(0)


BREAKAGES = {
    # name: (file, how to break it, expected file name, expected field fragment)
    "room missing field": ("rooms/kitchen_galley.toml",
                           lambda p: _sub(p, 'kind = "kitchen"\n', ""),
                           "kitchen_galley.toml", "kind"),
    "room unknown material": ("rooms/kitchen_galley.toml",
                              lambda p: _sub(p, 'ceiling = "', 'ceiling = "unobtainium_'),
                              "kitchen_galley.toml", "materials.m1.ceiling"),
    "zone outside the room": ("rooms/kitchen_galley.toml",
                              lambda p: p.write_text(re.sub(r"rect = \[[^\]]*\]",
                                                            "rect = [-3.0, -3.0, -2.0, -2.0]",
                                                            p.read_text(), count=1)),
                              "kitchen_galley.toml", "].rect: outside the room"),
    "negative size": ("rooms/kitchen_galley.toml",
                      lambda p: _sub(p, _first_furniture_size(p.read_text()),
                                     "size = [-1.0, 0.6, 0.9]"),
                      "kitchen_galley.toml", "furniture[0].size"),
    "material negative density": ("materials/objects.toml",
                                  lambda p: _sub(p, "density_kg_m3 = 7850", "density_kg_m3 = -7850"),
                                  "objects.toml", "metal.density_kg_m3"),
    "material missing field": ("materials/objects.toml",
                               lambda p: p.write_text(re.sub(r"(\[glass\][^\[]*?)youngs_modulus_pa = [^\n]+\n",
                                                             r"\1", p.read_text(), count=1, flags=re.S)),
                               "objects.toml", "glass.youngs_modulus_pa"),
    "surface bad bands": ("materials/surfaces.toml",
                          lambda p: p.write_text(re.sub(r"absorption = \[([^,\]]+),", "absorption = [",
                                                        p.read_text(), count=1)),
                          "surfaces.toml", "absorption"),
    "category unknown material": ("objects/categories.toml",
                                  lambda p: _sub(p, "plastic_hard", "plastic_hardd"),
                                  "categories.toml", "materials"),
    "category missing field": ("objects/categories.toml",
                               lambda p: p.write_text(re.sub(r'\ndescription = "[^"]*"\n', "\n",
                                                             p.read_text(), count=1)),
                               "categories.toml", "description"),
    "texture bad parameter": ("materials/surfaces.toml",
                              lambda p: _sub(p, "board_width_m = 0.14, board_length_m = 1.8",
                                             "board_width_m = 9.0, board_length_m = 1.8"),
                              "surfaces.toml", "texture.board_width_m"),
    "texture unknown kind": ("materials/objects.toml",
                             lambda p: _sub(p, 'texture = { kind = "metal" }',
                                            'texture = { kind = "chrome" }'),
                             "objects.toml", "texture.kind"),
    "toml syntax": ("rooms/kitchen_galley.toml", lambda p: _sub(p, "size_m = [", "size_m = [[", 1),
                    "kitchen_galley.toml", "<syntax>"),
}


@pytest.mark.parametrize("name", sorted(BREAKAGES))
def test_malformed_file_gives_one_line_error(capsys, data_copy, tmp_path, name):
    rel, breaker, fname, field = BREAKAGES[name]
    breaker(data_copy / rel)
    out = tmp_path / "out.png"
    code, _, err = run(capsys, "rooms", "show", "kitchen_galley-l1-m1", "-o", str(out),
                       "--data-dir", str(data_copy))
    assert code == 2, err
    assert err.startswith("error: ") and err.count("\n") == 1, err
    assert fname in err and field in err, err
    assert not out.exists()


def test_bad_data_dir(capsys, tmp_path):
    code, _, err = run(capsys, "rooms", "list", "--data-dir", str(tmp_path))
    assert code == 2 and "not a fallgen data directory" in err


# --- rehearse ------------------------------------------------------------------------------------

def test_rehearse_bad_input(capsys, tmp_path):
    repo = Path(__file__).resolve().parents[1]
    out = tmp_path / "out"
    code, _, err = run(capsys, "rehearse", "-c", str(repo / "configs/smoke.toml"),
                       "--rooms", "no_such_room*", "--out", str(out))
    assert code == 2 and err.count("\n") == 1 and "no_such_room" in err
    broken = tmp_path / "broken.toml"
    broken.write_text((repo / "configs/smoke.toml").read_text().replace(
        "events_per_zone = 1", ""))
    code, _, err = run(capsys, "rehearse", "-c", str(broken), "--out", str(out))
    assert code == 2 and err.count("\n") == 1
    assert "broken.toml" in err and "rehearse.events_per_zone" in err
    assert not out.exists()


def test_rehearse_runs(capsys, tmp_path):
    repo = Path(__file__).resolve().parents[1]
    cfg = tmp_path / "tiny.toml"
    cfg.write_text((repo / "configs/smoke.toml").read_text().replace(
        'rooms = "kitchen_galley-l1-m1,study_office-l1-m1"',
        'rooms = "kitchen_galley-l1-m1"\nzones = "z0[0-1]"'))
    code, out, err = run(capsys, "rehearse", "-c", str(cfg), "--out", str(tmp_path / "o"))
    assert code == 0, err
    assert (tmp_path / "o/rehearsal/kitchen_galley-l1-m1.parquet").exists()
    assert "rehearsal by zone kind" in out and "events kept of" in out
    # what the process that did the work used (one variant: rehearsed in this process)
    assert re.search(r"rehearsal: 1 process, peak memory \d+ MB, CPU \d+ s", out), out


def test_sounds_writes_wav_and_png(capsys, tmp_path, world, monkeypatch):
    """`fallgen sounds`: a WAV (float32 pascals) and a spectrogram per event; a file that is
    not a rehearsal file is a one-line error, exit 2."""
    import numpy as np
    import pyarrow.parquet as pq
    import soundfile as sf

    from fallgen.config import RehearseConfig
    from fallgen.physics.drop import run_trial
    from fallgen.physics.events import to_table

    monkeypatch.setenv("FALLGEN_CACHE", str(tmp_path / "cache"))
    v = world.variant("study_loft-l1-m1")
    small = ("key", "pen", "spoon", "shirt_button", "coaster", "knife", "fork", "golf_ball")
    ev = next(o.event for z in v.zones for t in range(3)
              for o in [run_trial(world, v, z, t, RehearseConfig(), 5)]
              if o.event is not None and o.event.target.category in small)
    f = tmp_path / "ev.parquet"
    pq.write_table(to_table([ev]), f)
    code, out, err = run(capsys, "sounds", str(f), "-o", str(tmp_path / "out"))
    assert code in (0, None), err
    stem = ev.event_id.replace("/", "_")
    data, fs = sf.read(tmp_path / "out" / f"{stem}.wav", dtype="float32")
    assert fs == 44100 and len(data) == 2 * fs
    # the fall's dry sound as the renderer makes it (the command's seed 0, event 0)
    from fallgen.audio.fall import FallRenderer

    ref = np.sum([x.signal for x in FallRenderer(world).render_sources(
        ev, np.random.default_rng(np.random.SeedSequence(0, spawn_key=(0,))))], axis=0)
    assert np.abs(ref).max() > 0
    assert np.allclose(data, ref.astype(np.float32), atol=1e-6 * np.abs(ref).max())
    assert (tmp_path / "out" / f"{stem}.png").stat().st_size > 1000
    # --binaural: the same fall heard in the room, two ears (the measured head by default)
    code, out, err = run(capsys, "sounds", str(f), "-o", str(tmp_path / "b"), "--binaural")
    assert code in (0, None), err
    data, fs = sf.read(tmp_path / "b" / f"{stem}.binaural.wav", dtype="float32")
    assert data.shape == (2 * fs, 2) and np.isfinite(data).all() and np.abs(data).max() > 0
    assert "binaural peak" in out
    notsofa = tmp_path / "h.sofa"
    notsofa.write_bytes(b"not hdf5")
    code, out, err = run(capsys, "sounds", str(f), "-o", str(tmp_path / "b2"), "--binaural",
                         "--hrtf", str(notsofa))
    assert code == 2 and err.strip().count("\n") == 0 and "h.sofa" in err
    bad = tmp_path / "bad.parquet"
    bad.write_bytes(b"nope")
    code, out, err = run(capsys, "sounds", str(bad), "-o", str(tmp_path / "o2"))
    assert code == 2 and err.strip().count("\n") == 0 and "bad.parquet" in err
    assert not (tmp_path / "o2").exists()


# --- checks before any work ----------------------------------------------------------------------

@pytest.mark.parametrize(("old", "new", "message"), [
    ('rooms = "kitchen_galley-l1-m1,study_office-l1-m1"',
     'rooms = "kitchen_galley-l1-m1,study_office-l1-m1"\nzones = "z9*"', "matches no zone"),
    ('rooms = "kitchen_galley-l1-m1,study_office-l1-m1"',
     'rooms = "kitchen_galley-l1-m1,study_office-l1-m1"\nzones = "z00"',
     "leaves at most 1 kitchen fall events, fewer than the 3 splits"),
])
def test_build_checks_the_zones_before_any_work(capsys, tmp_path, old, new, message):
    """Zones that leave no event, or fewer than the splits need, are refused before the
    rehearsal (which used to run first and then fail with a traceback)."""
    repo = Path(__file__).resolve().parents[1]
    cfg = tmp_path / "z.toml"
    cfg.write_text((repo / "configs/smoke.toml").read_text().replace(old, new))
    out = tmp_path / "out"
    code, _, err = run(capsys, "build", "-c", str(cfg), "--out", str(out))
    assert code == 2 and err.count("\n") == 1, err
    assert "z.toml: rehearse.zones" in err and message in err
    assert not out.exists()


def test_build_refuses_a_source_tree(capsys, tmp_path):
    """`--out .` in a checkout (or `out = ""`) once wrote the card over its README.md."""
    repo = Path(__file__).resolve().parents[1]
    readme = (repo / "README.md").read_bytes()
    code, _, err = run(capsys, "build", "-c", str(repo / "configs/smoke.toml"), "--out",
                       str(repo))
    assert code == 2 and err.count("\n") == 1 and "pyproject.toml" in err, err
    assert (repo / "README.md").read_bytes() == readme
    assert not (repo / ".fallgen").exists()
