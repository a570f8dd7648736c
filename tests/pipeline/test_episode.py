"""One episode from a rehearsed fall (fallgen.pipeline.episode): the expert always succeeds
(checked by rendering its final view), spawns are free and far, episodes depend only on their id,
and the audio comes from the right side."""

from __future__ import annotations

import math

import numpy as np
import pytest

from fallgen.audio.hrtf import spherical_head
from fallgen.audio.mix import Binaural
from fallgen.audio.room import RirSettings
from fallgen.config import RehearseConfig
from fallgen.nav.agent import VISIBLE_PIXELS, AgentSpec, Pose
from fallgen.physics.drop import run_trial
from fallgen.pipeline.episode import MIN_SPAWN_DISTANCE_M, EpisodeMaker, Skip

VARIANT = "kitchen_galley-l1-m1"


@pytest.fixture(scope="module")
def events(world):
    v = world.variant(VARIANT)
    out = []
    for z in v.zones:
        o = run_trial(world, v, z, 0, RehearseConfig(), 1)
        if o.event is not None and o.event.zone_kind != "cabinet_top":
            out.append(o.event)
        if len(out) == 5:
            break
    return out


@pytest.fixture(scope="module")
def maker(world, tmp_path_factory):
    import os

    os.environ.setdefault("FALLGEN_CACHE", str(tmp_path_factory.mktemp("cache")))
    return EpisodeMaker(world, Binaural(spherical_head()), rir=RirSettings(length_s=2.0))


@pytest.fixture(scope="module")
def episodes(maker, events):
    out = []
    for i, e in enumerate(events):
        try:
            out.append(maker.make(i, e, 11))
        except Skip:
            pass
    assert len(out) >= 3
    return out


def test_expert_succeeds_and_is_checked_by_rendering(maker, episodes, world):

    for ep in episodes:
        acts = ep.expert.plan.actions
        # SPL = l / max(p, l) with p the expert's own path; SNA = n* / max(n, n*)
        assert ep.expert_spl == ep.expert.shortest_m / max(ep.expert.plan.path_m,
                                                           ep.expert.shortest_m) == 1.0
        assert ep.expert_sna == ep.expert.fewest_actions / max(len(acts),
                                                               ep.expert.fewest_actions)
        assert acts[-1] == 5 and len(acts) <= 200
        # final pose: within 2 m, and the renderer sees the object there
        goal = ep.expert.plan.goal
        centre = np.asarray(ep.event.settle_pos)
        assert np.hypot(*(goal.xy - centre[:2])) <= 2.0 + 0.15
        assert ep.view.rgb.shape == (300, 300, 3)


def test_spawns_are_free_and_far(episodes):
    spec = AgentSpec()
    for ep in episodes:
        c = np.asarray(ep.event.settle_pos)[:2]
        assert np.hypot(ep.spawn.x - c[0], ep.spawn.y - c[1]) >= MIN_SPAWN_DISTANCE_M - 0.1
        assert ep.grid.free_for(ep.spawn.xy[None], spec.radius_m)[0]
        if not ep.spawn_sees_object:
            assert ep.view.pixels_of("obj:target") < VISIBLE_PIXELS


def test_episode_depends_only_on_its_id(maker, events, episodes):
    ep = episodes[0]
    i = next(k for k, e in enumerate(events) if e is ep.event)
    again = maker.make(ep.episode_id, events[i], 11)
    assert again.spawn == ep.spawn
    assert np.array_equal(again.audio.audio, ep.audio.audio)
    assert again.expert.plan.actions == ep.expert.plan.actions
    other = maker.make(ep.episode_id + 100, events[i], 11)
    assert other.spawn != ep.spawn


def test_an_episode_is_the_same_after_its_rooms_were_forgotten(maker, events, episodes):
    """A worker moving on to the other room kind forgets this variant's rooms
    (``retain_rooms``); made again from nothing, the episode is the same, byte for byte."""
    from fallgen.physics.events import event_variant

    assert {event_variant(e.event_id) for e in events} == {VARIANT}  # what the ids name
    ep = episodes[0]
    i = next(k for k, e in enumerate(events) if e is ep.event)
    assert maker.rooms_kept == {VARIANT}
    maker.retain_rooms({VARIANT})  # its own kept
    assert maker.rooms_kept == {VARIANT}
    maker.retain_rooms({"study_loft-l1-m1"})
    assert maker.rooms_kept == frozenset()
    again = maker.make(ep.episode_id, events[i], 11)
    assert maker.rooms_kept == {VARIANT}
    assert again.spawn == ep.spawn
    assert np.array_equal(again.audio.audio, ep.audio.audio)
    assert np.array_equal(again.view.rgb, ep.view.rgb)
    assert np.array_equal(again.view.depth, ep.view.depth)
    assert again.expert.plan.actions == ep.expert.plan.actions


def test_appearance_changes_only_the_colours(maker, world, events, episodes):
    """``appearance=True`` (textures, a shadow-casting light): the same episode (spawn,
    audio, expert), the same segmentation and depth (to float rounding) at step 0, and an RGB
    view with more detail."""
    from fallgen.vision.textures import detail_share

    ep = episodes[0]
    i = next(k for k, e in enumerate(events) if e is ep.event)
    look = EpisodeMaker(world, maker.binaural, rir=maker.rir, appearance=True)
    try:
        again = look.make(ep.episode_id, events[i], 11)
    finally:
        look.close()
    assert again.spawn == ep.spawn and again.expert.plan.actions == ep.expert.plan.actions
    assert np.array_equal(again.audio.audio, ep.audio.audio)
    assert np.array_equal(again.view.instance, ep.view.instance)
    np.testing.assert_allclose(again.view.depth, ep.view.depth, atol=1e-4)
    assert detail_share(again.view.rgb) > detail_share(ep.view.rgb)


def test_a_look_of_its_own_changes_only_the_colours(maker, world, events, episodes):
    """``appearance_randomization``: each episode drawn in its own look (from its own seed): the
    same episode otherwise (spawn, audio, expert, segmentation), and another episode id gives
    another look of the same room."""
    from fallgen.pipeline.episode import appearance_seed

    ep = episodes[0]
    i = next(k for k, e in enumerate(events) if e is ep.event)
    plain = EpisodeMaker(world, maker.binaural, rir=maker.rir, appearance=True)
    rand = EpisodeMaker(world, maker.binaural, rir=maker.rir, appearance=True,
                        appearance_randomization=True)
    try:
        a = plain.make(ep.episode_id, events[i], 11)
        b = rand.make(ep.episode_id, events[i], 11)
        b2 = rand.make(ep.episode_id, events[i], 11)
    finally:
        plain.close()
        rand.close()
    assert b.spawn == a.spawn and b.expert.plan.actions == a.expert.plan.actions
    assert np.array_equal(b.audio.audio, a.audio.audio)
    assert np.array_equal(b.view.instance, a.view.instance)
    assert np.array_equal(b.view.rgb, b2.view.rgb)
    assert not np.array_equal(b.view.rgb, a.view.rgb)
    assert appearance_seed(11, ep.episode_id) != appearance_seed(11, ep.episode_id + 1)
    with pytest.raises(ValueError, match="appearance"):
        EpisodeMaker(world, maker.binaural, appearance_randomization=True)


def test_a_fall_too_quiet_to_hear_starts_no_episode(maker, events, episodes):
    """``min_heard_peak_db_spl``: an episode whose fall peaks below it at the agent is skipped
    ("inaudible"; the shard tries the episode's next event); at or under the heard level it
    is the same episode."""
    ep = episodes[0]
    i = next(k for k, e in enumerate(events) if e is ep.event)
    peak = ep.audio.fall_levels[0]
    maker.min_heard_peak_db_spl = peak + 0.1
    try:
        with pytest.raises(Skip, match="inaudible"):
            maker.make(ep.episode_id, events[i], 11)
        maker.min_heard_peak_db_spl = peak - 0.1
        again = maker.make(ep.episode_id, events[i], 11)
        assert np.array_equal(again.audio.audio, ep.audio.audio)
    finally:
        maker.min_heard_peak_db_spl = 0.0


def test_object_on_the_left_is_louder_and_earlier_in_the_left_ear(maker, episodes):
    ep = episodes[0]
    c = np.asarray(ep.event.settle_pos)
    # stand 2.5 m from the object, facing so that it is 90 degrees to the left
    for k in range(12):
        heading = k
        yaw = math.radians(30 * k)
        left = np.array([-math.sin(yaw), math.cos(yaw)])
        p = c[:2] - 2.5 * left
        if ep.grid.free_for(p[None], 0.3)[0]:
            break
    else:
        pytest.skip("no free place to the object's right")
    e2 = maker.make(ep.episode_id, ep.event, 11, spawn=Pose(float(p[0]), float(p[1]), heading))
    pa = e2.audio.pressure_pa()
    first = min(c_.time_s for c_ in ep.event.contacts)
    i0 = int(first * 44100)
    w = pa[:, i0:i0 + int(0.012 * 44100)]  # the direct sound of the first contact
    # the head shadows what is above ~2 kHz (the floor's thud below is heard by both ears)
    from scipy.signal import butter, sosfilt
    hi = sosfilt(butter(4, 2000, "highpass", fs=44100, output="sos"), pa, axis=1)
    hw = hi[:, i0:i0 + int(0.012 * 44100)]
    assert (hw[0] ** 2).sum() > 2 * (hw[1] ** 2).sum()
    onset = [int(np.argmax(np.abs(w[e]) > 0.2 * np.abs(w[e]).max())) for e in (0, 1)]
    assert onset[0] < onset[1]


def test_trajectory_frames_follow_the_expert(maker, events, episodes):
    ep = episodes[1]
    i = next(k for k, e in enumerate(events) if e is ep.event)
    full = maker.make(ep.episode_id, events[i], 11, frames="trajectory")
    assert len(full.frames) == len(full.expert.plan.actions) + 1
    assert np.array_equal(full.frames[0].rgb, full.view.rgb)  # step 0 is the first view
    last = full.frames[-1]
    assert last.pixels_of("obj:target") >= VISIBLE_PIXELS  # the final view sees the object


def test_a_skipped_attempt_reports_the_time_it_spent(maker, events, monkeypatch):
    """An attempt given up in its search (no path) still accounts for its time: the Skip
    carries the seconds of the stages it went through, the search's charged to planning
    (here a search that takes at least 0.2 s by the clock before it answers)."""
    import time

    from fallgen.nav.expert import NoPath
    from fallgen.pipeline import settled

    def slow_no_path(self, start):
        time.sleep(0.2)
        raise NoPath("hidden")

    monkeypatch.setattr(settled.SettledRoom, "expert", slow_no_path)
    with pytest.raises(Skip) as e:
        maker.make(0, events[0], 11)
    assert e.value.reason == "no_path"
    t = e.value.timings_s
    assert set(t) == {"maps", "spawn", "planning"}
    assert 0.2 <= t["planning"] < 5.0
    assert t["maps"] > 0


def test_the_build_gives_up_a_search_at_its_own_state_limit(maker, events, episodes,
                                                             monkeypatch):
    """The build's expert searches under ``BUILD_LIMITS`` (fewer states than the search's
    own default): an episode it makes is given up (``search_limit``) when they allow less
    than its search needs (here no renderer verdict at all)."""
    from fallgen.nav.expert import Limits
    from fallgen.pipeline import settled

    assert settled.BUILD_LIMITS.states < Limits().states
    ep = episodes[0]
    i = next(k for k, e in enumerate(events) if e is ep.event)
    monkeypatch.setattr(settled, "BUILD_LIMITS", Limits(verdicts=0))
    with pytest.raises(Skip) as e:
        maker.make(ep.episode_id, events[i], 11)
    assert e.value.reason == "search_limit"


def test_an_event_proven_hidden_is_not_searched_again_from_the_same_cells(world, maker, events,
                                                                         monkeypatch):
    """Once the proof that no reachable pose sees the object holds for an event, another
    attempt at it whose spawn reaches the same cells is given up (no_path) without a search;
    another event, or the same event from other cells, is searched."""
    from fallgen.nav.expert import HiddenEverywhere
    from fallgen.pipeline import settled

    asked = []

    def proven(self, start):
        asked.append(self.event.event_id)
        raise HiddenEverywhere("hidden")

    monkeypatch.setattr(settled.SettledRoom, "expert", proven)
    maker = EpisodeMaker(world, maker.binaural, rir=maker.rir)  # its own memory of proofs
    for _ in range(2):
        with pytest.raises(Skip) as e:
            maker.make(0, events[1], 11)
        assert e.value.reason == "no_path"
    assert asked == [events[1].event_id]
    with pytest.raises(Skip):
        maker.make(0, events[2], 11)
    assert asked == [events[1].event_id, events[2].event_id]
    monkeypatch.setattr(settled.SettledRoom, "reachable_key", lambda self, start: b"other")
    with pytest.raises(Skip):
        maker.make(0, events[1], 11)
    assert asked[-1] == events[1].event_id and len(asked) == 3


#: run in a fresh process: compile ahead on the first event, then make the others' episodes
#: (each search trying the proof that no reachable pose sees the object at once, as the long
#: searches of a build do) and print the compiled functions that gained a specialisation
AHEAD = """
import json, pickle, sys
from numba.core.dispatcher import Dispatcher
from fallgen.audio.hrtf import spherical_head
from fallgen.audio.mix import Binaural
from fallgen.audio.room import RirSettings
from fallgen.nav import expert
from fallgen.pipeline.episode import EpisodeMaker, Skip
from fallgen.world.library import load_world

def compiled():
    return {(m.__name__, n, tuple(map(str, d.signatures)))
            for m in list(sys.modules.values()) if getattr(m, "__name__", "").startswith("fallgen")
            for n, d in vars(m).items() if isinstance(d, Dispatcher)}

events = pickle.loads(open(sys.argv[1], "rb").read())
maker = EpisodeMaker(load_world(), Binaural(spherical_head()), rir=RirSettings(length_s=2.0))
maker.compile_ahead(events[0], 11)
before = compiled()
expert.PROOF_AFTER_STATES = expert.PROOF_AFTER_VERDICTS = 0
made = 0
for i, e in enumerate(events[1:]):
    try:
        maker.make(i, e, 11)
        made += 1
    except Skip:
        pass
print(json.dumps({"made": made, "ahead": sum(bool(s) for _, _, s in before),
                  "new": sorted(f"{m}.{n}" for m, n, _ in compiled() - before)}))
"""


def test_compiling_ahead_leaves_the_episodes_nothing_to_compile(events, maker, tmp_path):
    """After :meth:`EpisodeMaker.compile_ahead` on one event, the episodes of the others, with
    their searches' proofs and the falls' replays, specialise no compiled function further: a
    build's workers, started after a process that compiled ahead, only load compiled code
    (compiling it themselves cost each ~250 MB more)."""
    import json
    import pickle
    import subprocess
    import sys

    (tmp_path / "events.pkl").write_bytes(pickle.dumps(events))
    out = subprocess.run([sys.executable, "-c", AHEAD, str(tmp_path / "events.pkl")],
                         capture_output=True, text=True, check=True)
    got = json.loads(out.stdout.strip().splitlines()[-1])
    assert got["made"] >= 2, got
    assert got["new"] == [], got
    assert got["ahead"] >= 20, got  # the search, the occlusion bounds, the proof, the replay
