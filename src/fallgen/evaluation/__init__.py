"""Evaluating agents on a built dataset (``fallgen evaluate``) and exporting the expert's
trajectories for imitation learning (``fallgen export-expert``).

- :mod:`.runner`: every selected episode once, in worker processes, sorted by id;
- :mod:`.scores`: means, bootstrap 95 % intervals, breakdowns, the paper's Table 1;
- :mod:`.evaluate`: selection, scoring and ``episodes.jsonl`` / ``summary.json``;
- :mod:`.trajectories`: per-step observations along ``expert_actions`` (HDF5 or Minari).
"""

from fallgen.evaluation.evaluate import Evaluation, evaluate, load_actions, write
from fallgen.evaluation.runner import AgentRef, play, run_episodes

__all__ = ["AgentRef", "Evaluation", "evaluate", "load_actions", "play", "run_episodes",
           "write"]
