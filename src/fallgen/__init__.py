"""fallgen: offline, deterministic generator of the Fallen Objects audio-visual dataset.

The package mirrors the data flow: ``world`` (materials, objects, rooms, MuJoCo scenes) feeds
the later stages (physics, audio, vision, navigation, dataset writer). The CLI in ``cli`` is a
thin layer over these library functions.
"""

__version__ = "0.2.0"

import os as _os

# Headless rendering: MuJoCo picks its OpenGL backend when it is first imported, so choose EGL
# (Mesa's software rasteriser on a machine without a GPU) before anything imports it, unless
# the user chose (MUJOCO_GL=osmesa also works).
_os.environ.setdefault("MUJOCO_GL", "egl")
# Bit-for-bit reproducible output: a multi-threaded BLAS sums in an order that depends on its
# thread count (last-bit differences in the audio), so numpy's BLAS runs one thread (parallelism
# is by worker processes). Takes effect when fallgen is imported before numpy (the CLI does).
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    _os.environ.setdefault(_var, "1")
# Mesa's CPU rasteriser (llvmpipe, what EGL gives without a GPU) hands every draw to rasteriser
# threads of its own (one per core by default) and the caller waits for them when it reads the
# pixels back: 0 rasterises in the calling thread instead. Parallelism is by worker processes;
# the pixels are the same. One process alone on the machine made a full-size shard in 18.2-19.3 s
# of CPU against 20.4-22.0 s with one rasteriser thread; with every core busy (a build's workers)
# the two cost the same (two shards side by side, and a full build: 8.5 min, the same files, as
# with one thread). Read when the first GL context is made.
_os.environ.setdefault("LP_NUM_THREADS", "0")
# Compiled functions are cached per version of the package's sources (fallgen.jitcache): Numba's
# own cache would keep serving a function compiled against an older version of a module it calls.
from fallgen import jitcache as _jitcache  # noqa: E402

_jitcache.configure()
