"""`fallgen assets modes` precomputes exactly what rendering a fall asks for."""

from __future__ import annotations

import numpy as np

from fallgen.audio.catalog import jobs
from fallgen.audio.fall import AudioSettings, FallRenderer
from fallgen.audio.modes import ModalSettings, cache_key


def test_jobs_cover_what_a_fall_renders(world, tmp_path, drop_event):
    all_jobs = jobs(world)
    keys = {cache_key(j.vertices, j.faces, j.nu, ModalSettings()) for j in all_jobs}
    assert len(keys) == len(all_jobs)  # no job twice
    labels = {j.label for j in all_jobs}
    for cat in world.categories:
        for v in cat.variants:
            # every solid variant is a job; thin shells (cans, toaster) have closed-form modes
            shell = world.categories.geometry(cat.id, v.name).shell is not None
            assert (f"{cat.id}/{v.name}" in labels) != shell, (cat.id, v.name)
    assert not any(label.startswith("panel/") for label in labels)  # room surfaces: plates
    r = FallRenderer(world, AudioSettings(cache_dir=tmp_path, length_s=1.0))
    e = drop_event(world, "key", "house", "metal/brass", 0.6, steps=500)
    r.render(e, np.random.default_rng(0))
    made = {p.stem for p in tmp_path.glob("*.npz")}
    assert made and made <= keys, made - keys
