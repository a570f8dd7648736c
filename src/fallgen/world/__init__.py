"""The world: materials, object categories, rooms and the MuJoCo scenes built from them."""
