"""Audio: the sound of a fall, from physics contacts to the binaural clip at the agent's ears.

- :mod:`~fallgen.audio.fem`: voxel finite elements, eigenmodes.
- :mod:`~fallgen.audio.voxelize`: watertight mesh -> voxel solid.
- :mod:`~fallgen.audio.shells`: thin-walled bodies' modes (closed form).
- :mod:`~fallgen.audio.modes`: per-shape modal models, rescaling, on-disk cache.
- :mod:`~fallgen.audio.hertz`: Hertz contact duration and force.
- :mod:`~fallgen.audio.coupling`: an impact as a contact with the bodies' modes (energy).
- :mod:`~fallgen.audio.impact`: hits on modal bodies -> pressure at 1 m; radiated energy.
- :mod:`~fallgen.audio.fall`: a whole fall event's dry sound, per source; its energy account.
- :mod:`~fallgen.audio.room`, :mod:`~fallgen.audio.hrtf`, :mod:`~fallgen.audio.mix`: the room,
  the head, the binaural clip.
"""

#: The most of the energy a fall loses that its sound may carry. Measured impacts radiate
#: ~1e-4 to 1e-2 of the impact energy (Koss & Alfredson 1973; Akay 1978, "A review of impact
#: noise"); a few per cent bounds ringing thin-walled bodies. Every episode's
#: ``audio_energy_ratio`` is checked against it (``fallgen stats``).
AUDIO_ENERGY_CEILING = 0.05
