"""Physics: dropping objects in room scenes, detecting settling, recording contacts.

MuJoCo reports a diverging simulation by printing a warning and appending it to
``MUJOCO_LOG.TXT`` in the working directory. fallgen reads the same information from
``MjData.warning`` counters (every such trial is rejected and counted as ``unstable``), so the
text handler is replaced by one that stays silent and writes no file.
"""

import mujoco


def _silent(_msg: str) -> None:
    return None


mujoco.set_mju_user_warning(_silent)
