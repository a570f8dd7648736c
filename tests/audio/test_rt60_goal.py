"""The reverberation goal (furnished dwellings: 0.3-0.9 s at 500 Hz-1 kHz) judged on the ray
tracer, the reference, not on the model the late reverb is made to decay at: the rays' T30
beside the model on a sample of variants, and the verdict a dataset gets from the model
widened by the rays' measured ratio to it (audio.acoustics)."""

from __future__ import annotations

import pytest

from fallgen.audio.acoustics import (RAYS_OVER_MODEL, RT60_GOAL_S, rt60_checks,
                                     rt60_goal_from_model)


def test_rays_stay_within_the_stated_deviation(world):
    """On a sample of three variants (a hard kitchen, a kitchen absorbing on every side, a
    study absorbing on its floor and ceiling) the ray tracer's mid-frequency T30 is 1.04-1.97
    times the model's RT60, as RAYS_OVER_MODEL states it for all 64 (measured with the same
    rays and seeds), and the verdict of each is its T30 against RT60_GOAL_S."""
    sample = [world.variant(v) for v in ("kitchen_galley-l4-m2", "kitchen_island-l2-m2",
                                         "study_office-l4-m1")]
    lo, _, hi = RAYS_OVER_MODEL
    checks = rt60_checks(sample, world.materials)
    for c in checks:
        assert lo - 0.01 <= c.ratio <= hi + 0.01, (c.variant, c.ratio)
        assert c.ok == (RT60_GOAL_S[0] <= c.rays_t30_s <= RT60_GOAL_S[1])
    by = {c.variant: c for c in checks}
    # the tiled galley rings past the goal by the rays (1.04 s) while its model says 0.89 s
    galley = by["kitchen_galley-l4-m2"]
    assert galley.model_s < RT60_GOAL_S[1] < galley.rays_t30_s
    assert by["kitchen_island-l2-m2"].ratio < 1.15 < 1.6 < by["study_office-l4-m1"].ratio


@pytest.mark.parametrize("model_s, ok", [
    (0.4, True),    # 0.42-0.79 s: inside whatever the ratio
    (0.55, None),   # estimate 0.68 s inside, 0.57-1.08 s: undecided
    (0.8, False),   # estimate 0.98 s: outside
    (0.2, False),   # estimate 0.25 s: a studio, not a home
])
def test_verdict_from_the_model_and_the_rays_deviation(model_s, ok):
    """A dataset's variants carry the model's RT60 only: the goal is met when every variant
    times the rays' lowest and highest ratio to the model lies inside 0.3-0.9 s, missed when
    one's estimate (times the median ratio) lies outside, undecided between."""
    g = rt60_goal_from_model({"a": 0.45, "b": model_s})
    assert g["ok"] is ok
    lo, mid, hi = RAYS_OVER_MODEL
    assert g["value"] == pytest.approx([min(0.45, model_s) * mid, max(0.45, model_s) * mid])
    assert g["variants_outside"] == ([] if ok in (True, None) else ["b"])
