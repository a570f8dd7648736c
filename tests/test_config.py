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
