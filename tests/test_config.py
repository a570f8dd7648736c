"""Build configs: the shipped ones load; bad ones fail with one line naming file and field."""

from __future__ import annotations

from pathlib import Path

import pytest

from fallgen.config import load_config
from fallgen.errors import InputError

CONFIGS = sorted((Path(__file__).resolve().parents[1] / "configs").glob("*.toml"))


@pytest.mark.parametrize("path", CONFIGS, ids=lambda p: p.name)
def test_shipped_configs_load(path, world):
    cfg = load_config(path)
    assert world.variants(cfg.rehearse.rooms), path
    assert cfg.rehearse.drop_height_m[0] < cfg.rehearse.drop_height_m[1]


def test_full_config_has_enough_events():
    cfg = load_config(Path(__file__).resolve().parents[1] / "configs/full.toml")
    assert 64 * 20 * cfg.rehearse.events_per_zone >= 8000


@pytest.mark.parametrize(("old", "new", "field"), [
    ("events_per_zone = 1", "events_per_zone = 0", "rehearse.events_per_zone"),
    ("drop_height_m = [1.5, 2.8]", "drop_height_m = [2.8, 1.5]", "rehearse.drop_height_m"),
    ("timeout_s = 6.0", "timeout_s = 6.0\ntimout_s = 1", "rehearse.timout_s"),
    ("root_seed = 2022", "root_seed = -1", "build.root_seed"),
])
def test_bad_config(tmp_path, old, new, field):
    src = (Path(__file__).resolve().parents[1] / "configs/smoke.toml").read_text()
    assert old in src
    p = tmp_path / "bad.toml"
    p.write_text(src.replace(old, new))
    with pytest.raises(InputError) as e:
        load_config(p)
    assert "bad.toml" in str(e.value) and field in str(e.value) and "\n" not in str(e.value)


def test_appearance_randomization_needs_appearance(tmp_path):
    """Each episode's own look is drawn on textured views: on (appearance = true) it loads,
    with flat views it is an error naming the field."""
    src = (Path(__file__).resolve().parents[1] / "configs/smoke.toml").read_text()
    ok = tmp_path / "ok.toml"
    ok.write_text(src.replace("appearance_randomization = false",
                              "appearance_randomization = true"))
    assert load_config(ok).generate.appearance_randomization
    p = tmp_path / "bad.toml"
    p.write_text(src.replace("appearance = true ", "appearance = false ").replace(
        "appearance_randomization = false", "appearance_randomization = true"))
    with pytest.raises(InputError) as e:
        load_config(p)
    assert "bad.toml" in str(e.value) and "generate.appearance_randomization" in str(e.value)


SMOKE = Path(__file__).resolve().parents[1] / "configs/smoke.toml"
REPO = SMOKE.parents[1]


def _bad(tmp_path: Path, old: str, new: str) -> InputError:
    src = SMOKE.read_text()
    assert old in src
    p = tmp_path / "bad.toml"
    p.write_text(src.replace(old, new))
    with pytest.raises(InputError) as e:
        load_config(p)
    assert "bad.toml" in str(e.value) and "\n" not in str(e.value)
    return e.value


def test_an_unknown_key_is_named_as_unknown(tmp_path):
    """A misspelt key is reported as itself, not as the required key it displaced."""
    e = _bad(tmp_path, "audio_s = 2.0", "audio_seconds = 2.0")
    assert e.field == "generate.audio_seconds" and "unknown field" in e.message
    e = _bad(tmp_path, "events_per_zone = 1 ", "events_per_zon = 1 ")
    assert e.field == "rehearse.events_per_zon" and "unknown field" in e.message
    e = _bad(tmp_path, "[build]", "[biuld]")
    assert e.field == "biuld"


def test_seed_range(tmp_path):
    """Seeds are 64-bit signed integers in the dataset: 0 <= root_seed < 2**63."""
    e = _bad(tmp_path, "root_seed = 2022", f"root_seed = {2 ** 63}")
    assert e.field == "build.root_seed"
    ok = tmp_path / "ok.toml"
    ok.write_text(SMOKE.read_text().replace("root_seed = 2022", f"root_seed = {2 ** 63 - 1}"))
    assert load_config(ok).root_seed == 2 ** 63 - 1


def test_out_must_be_a_directory_of_its_own(tmp_path):
    """Not empty (the current directory: the card overwrote a checkout's README.md), not a
    source tree, not a directory whose README.md is not a dataset card."""
    e = _bad(tmp_path, 'out = "build/smoke"', 'out = ""')
    assert e.field == "build.out" and "empty" in e.message
    e = _bad(tmp_path, 'out = "build/smoke"', f'out = "{REPO}"')
    assert e.field == "build.out" and "pyproject.toml" in e.message
    mine = tmp_path / "notes"
    mine.mkdir()
    (mine / "README.md").write_text("my notes\n")
    e = _bad(tmp_path, 'out = "build/smoke"', f'out = "{mine}"')
    assert "not a fallgen dataset card" in e.message


def test_hrtf_file_and_utf8(tmp_path):
    e = _bad(tmp_path, 'hrtf = "sadie_ku100"', f'hrtf = "{tmp_path / "none.sofa"}"')
    assert e.field == "generate.hrtf" and "nor a SOFA file" in e.message
    e = _bad(tmp_path, 'hrtf = "sadie_ku100"', 'hrtf = ""')
    assert e.field == "generate.hrtf" and "sphere" in e.message
    p = tmp_path / "latin1.toml"
    p.write_bytes(SMOKE.read_text().replace("# Tiny build", "# Tiny build \xe9t\xe9").encode(
        "latin-1"))
    with pytest.raises(InputError) as e:
        load_config(p)
    assert "UTF-8" in str(e.value) and "latin1.toml" in str(e.value)
