"""The reference agents by name (``fallgen evaluate --baseline``): :func:`make_baseline`.

Each agent's module is imported only when it is asked for (the modular agent's learned
modules need scikit-learn, the visual one torch)."""

from __future__ import annotations

from collections.abc import Collection, Sequence

from fallgen.agents.base import ORACLES

BASELINES = ("expert", "random", "modular", "objectgoal")


def make_baseline(name: str, category_labels: Sequence[str] = (),
                  object_categories: Collection[str] = (),
                  oracles: Collection[str] | None = None, audio_model: str | None = None,
                  audio_top_k: int = 1, vision_model: str | None = None,
                  vision_device: str = "cpu"):
    """The reference agent ``name``; ``category_labels`` (the dataset's segmentation table)
    and ``object_categories`` (the target categories) for the modular agent, with ``oracles``
    (None: all three, or none with a vision model; empty: none), an audio model file
    (``fallgen audio-model train``) as its goal predictor (``audio_top_k`` categories taken
    for the object) and a vision model file (``fallgen vision-model train``) as its eyes
    where the segmentation oracle is off (run on ``vision_device``); for ``objectgoal``
    (``oracles``: none, or ``segmentation``) a vision model or the segmentation oracle.
    ValueError for a combination that makes no sense."""
    if name == "expert":
        from fallgen.agents.expert import ExpertAgent

        return ExpertAgent()
    if name == "random":
        from fallgen.agents.random_agent import RandomAgent

        return RandomAgent()
    if name not in BASELINES:
        raise ValueError(f"unknown baseline {name!r}: {', '.join(BASELINES)}")
    if audio_model and name != "modular":
        raise ValueError(f"an audio model is for the modular agent, not {name!r}")
    everything = ORACLES if name == "modular" and not vision_model else ()
    chosen = everything if oracles is None else tuple(oracles)
    if vision_model and "segmentation" in chosen:
        raise ValueError("a vision model is the agent's eyes where the segmentation oracle "
                         "is off: give one or the other")
    detector = None
    if vision_model:
        from fallgen.agents.vision_detector import VisionDetector

        detector = VisionDetector(vision_model, device=vision_device)
        if category_labels and tuple(category_labels) != detector.model.category_labels:
            raise ValueError(f"{vision_model}: the model segments another category table "
                             "than the environment's")
    if name == "objectgoal":
        from fallgen.agents.objectgoal import ObjectGoalAgent

        return ObjectGoalAgent(category_labels, object_categories, oracles=chosen,
                               detector=detector)
    from fallgen.agents.modular import ModularAgent

    predictor = None
    if audio_model:
        from fallgen.agents.audio_goal import AudioGoalPredictor

        predictor = AudioGoalPredictor(audio_model, top_k=audio_top_k)
    return ModularAgent(category_labels, object_categories, oracles=chosen,
                        predictor=predictor, detector=detector)


__all__ = ["BASELINES", "make_baseline"]
