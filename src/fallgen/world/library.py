"""Loading the whole world (materials, categories, rooms) from one data directory."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from fallgen.paths import data_root
from fallgen.world.materials import MaterialLibrary, load_materials
from fallgen.world.objects import CategoryLibrary, load_categories
from fallgen.world.rooms import RoomSpec, RoomVariant, load_rooms, select_variants


@dataclass(frozen=True)
class World:
    root: Path
    materials: MaterialLibrary
    categories: CategoryLibrary
    rooms: dict[str, RoomSpec]

    def variants(self, pattern: str = "*") -> list[RoomVariant]:
        return select_variants(self.rooms, pattern)

    def variant(self, variant_id: str) -> RoomVariant:
        for room in self.rooms.values():
            for v in room.variants:
                if v.id == variant_id:
                    return v
        raise KeyError(f"no room variant {variant_id!r}")


def load_world(root: str | Path | None = None) -> World:
    """Load and validate every data file; raises ``InputError`` on the first bad field."""
    root = data_root(root)
    materials = load_materials(root / "materials")
    categories = load_categories(root / "objects", materials)
    rooms = load_rooms(root / "rooms", materials, frozenset(categories.ids()))
    return World(root, materials, categories, rooms)
