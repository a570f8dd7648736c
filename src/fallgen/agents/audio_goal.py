"""The learned audio module as the modular agent's goal predictor: the step-0 clip
-> where the fall was (in the spawn's frame, with the model's uncertainty) and what fell.

The paper's modular agent does the same with a ResNet-18 on spectrograms; ours is
:class:`fallgen.perception.audio_model.AudioModel`. ``top_k`` > 1 hands the agent the k most
likely categories, ranked: it then takes an object of any of them for the fallen one (more
falls found when the first guess is wrong, more wrong claims at distractors).
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

import numpy as np

from fallgen.agents.modular import GoalEstimate
from fallgen.perception.audio_model import AudioModel


class AudioGoalPredictor:
    """A :class:`fallgen.agents.modular.GoalPredictor` from an audio model (or its file).
    ``radius_m``: how far around the estimate the agent searches (default: the model's
    out-of-bag median position error)."""

    sensors = ("audio",)

    def __init__(self, model: AudioModel | str | Path, top_k: int = 1,
                 radius_m: float | None = None) -> None:
        if top_k < 1:
            raise ValueError(f"top_k={top_k}: at least 1")
        self.model = model if isinstance(model, AudioModel) else AudioModel.load(Path(model))
        self.top_k = int(top_k)
        self.radius_m = float(self.model.position_error_m if radius_m is None else radius_m)

    def predict(self, obs: Mapping[str, np.ndarray]) -> GoalEstimate:
        p = self.model.predict(np.asarray(obs["audio"], np.float32))
        ranked = tuple(p.categories[i] for i in np.argsort(-p.category_p, kind="stable"))
        return GoalEstimate(position=p.position, radius_m=self.radius_m, category=ranked[0],
                            categories=ranked[:self.top_k])


__all__ = ["AudioGoalPredictor"]
