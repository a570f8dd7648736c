"""fallgen: offline, deterministic generator of the Fallen Objects audio-visual dataset.

The package mirrors the data flow: ``world`` (materials, objects, rooms, MuJoCo scenes) feeds
the later stages (physics, audio, vision, navigation, dataset writer). The CLI in ``cli`` is a
thin layer over these library functions.
"""

__version__ = "0.1.0"

import os as _os

# Headless rendering: MuJoCo picks its OpenGL backend when it is first imported, so choose EGL
# (Mesa's software rasteriser on a machine without a GPU) before anything imports it, unless
# the user chose (MUJOCO_GL=osmesa also works).
_os.environ.setdefault("MUJOCO_GL", "egl")
