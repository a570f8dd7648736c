"""The paper's learned navigation policies, trained on a build and scored by ``fallgen evaluate``.

- ``ppo``: PPO with a recurrent (LSTM) policy and the oracle ``found`` (the episode ends in
  success once the object is within 2 m and in view; the policy moves only), sb3-contrib's
  ``RecurrentPPO`` on the environment's vector env (:mod:`.ppo`);
- ``dt``: a Decision Transformer trained offline on the expert's trajectories
  (``fallgen export-expert``), the last 20 steps' return-to-go, state and action tokens into
  a small GPT (:mod:`.dt`);
- ``savi``: SAVi: an audio goal descriptor (the object's category and place, learned from the
  step-0 clip as the auditory perception module is, then fine-tuned online with the true
  place) and a transformer memory over the last steps' observations, trained with PPO
  (:mod:`.savi`).

All three see the same observations through the same encoder (:mod:`.encoder`): the
environment's rgb, depth and category segmentation made 84 x 84, the step-0 clip's 2 x 64
log-mel bands held for the episode (:class:`fallgen.env.wrappers.Compactor`) and the pose.

``fallgen train {ppo,dt,savi} DATASET -o RUN`` (:mod:`fallgen.cli_train`) writes a run
directory (:mod:`.runs`): ``run.json`` (kind, dataset, manifest hash, settings),
``checkpoints/ckpt-NNNNNN.pt`` (resumed from the last one; one from another dataset is
refused), ``log.csv`` and ``curve.png``; ``fallgen evaluate DATASET --agent RUN`` plays the
last checkpoint (:mod:`.agent`). Everything here imports torch only when used: ``fallgen``
works without the ``learn`` extra.

Default budgets (2 CPU cores; each run stops after ``--minutes`` with a checkpoint and goes
on where it stopped when started again): Decision Transformer 60 min, PPO and SAVi 3 h each.
The settings of the paper's scale on a GPU are in each module's docstring and
``docs/policies.md``.
"""

from __future__ import annotations

#: The learned policies ``fallgen train`` knows.
KINDS = ("ppo", "dt", "savi")
#: The environment sensors the learned policies observe (category_seg is an oracle sensor:
#: the segmentation the paper's agents were given).
SENSORS = ("rgb", "depth", "audio", "pose", "category_seg")

__all__ = ["KINDS", "SENSORS"]
