"""The dataset card counts the target categories of the world data (31 in fallgen's own, the
paper's), not a number written into the schema's text."""

from __future__ import annotations

import pytest

pytestmark = pytest.mark.xdist_group("tiny_build")


def test_the_card_counts_the_worlds_target_categories(world, data_copy, monkeypatch):
    from fallgen.dataset.card import target_categories

    assert target_categories() == len(world.categories.ids("target")) == 31
    # a world with one target category less (it becomes an occluder)
    f = data_copy / "objects" / "categories.toml"
    f.write_text(f.read_text().replace('role = "target"', 'role = "occluder"', 1))
    monkeypatch.setenv("FALLGEN_DATA", str(data_copy))
    assert target_categories() == 30


def test_a_built_card_says_31(tiny_dataset):
    card = (tiny_dataset / "README.md").read_text()
    line = next(x for x in card.splitlines() if x.startswith("| `category` |"))
    assert "one of 31 target categories" in line
