"""Audio: modal impact synthesis from physics contacts (issue 4); room acoustics and binaural
rendering come next.

- :mod:`~fallgen.audio.fem`: voxel finite elements, eigenmodes.
- :mod:`~fallgen.audio.voxelize`: watertight mesh -> voxel solid.
- :mod:`~fallgen.audio.modes`: per-shape modal models, rescaling, on-disk cache.
- :mod:`~fallgen.audio.hertz`: Hertz contact duration and force.
- :mod:`~fallgen.audio.impact`: impulses on modal bodies -> pressure at 1 m.
"""
