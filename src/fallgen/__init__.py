"""fallgen: offline, deterministic generator of the Fallen Objects audio-visual dataset.

The package mirrors the data flow: ``world`` (materials, objects, rooms, MuJoCo scenes) feeds
the later stages (physics, audio, vision, navigation, dataset writer). The CLI in ``cli`` is a
thin layer over these library functions.
"""

__version__ = "0.1.0"
