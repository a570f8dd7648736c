"""What strikes a sounding body: single impacts (:class:`ModalHit`) and the trains of small
impulses a scrape or a roll makes (:class:`HitTrain`), and the hit tables the renderers read.

A scrape or roll sample of 10 ms makes one impulse per roughness wavelength travelled, all at
the same contact point, along the same direction and of the same length: hundreds per fall,
kept as arrays of one train, not as an object each (120 paper-size falls: 136 354 hit objects
before, 13 545 hits and trains now; the same sound to the bit).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class ModalHit:
    """An impulse on a body: when, where (body frame), along which unit direction (body frame;
    None = the surface normal there), how strong, and how long the force pulse lasts."""

    time_s: float
    point: np.ndarray
    impulse_ns: float
    duration_s: float
    direction: np.ndarray | None = None
    #: An impact solved as a contact with the body's modes
    #: (:func:`fallgen.audio.coupling.coupled_impact`): every mode's displacement and velocity
    #: when the bodies part, and when that is after ``time_s``. The modes then ring from that
    #: state instead of from the impulse (which still makes the rigid-body noise).
    modal_state: tuple[np.ndarray, np.ndarray, float] | None = None
    #: The contact force as a train of half-sine pulses, one per contact interval of a contact
    #: that chatters: (start after ``time_s`` (s), impulse (N s), duration (s)) each; their
    #: impulses sum to ``impulse_ns``. None: one pulse of ``impulse_ns`` lasting
    #: ``duration_s`` from ``time_s``.
    pulses: tuple[tuple[float, float, float], ...] | None = None

    def force_pulses(self) -> tuple[tuple[float, float, float], ...]:
        """(start (s), impulse (N s), duration (s)) of each half-sine pulse of the force."""
        if self.pulses is None:
            return ((self.time_s, self.impulse_ns, self.duration_s),)
        return tuple((self.time_s + t, j, d) for t, j, d in self.pulses)


@dataclass(frozen=True)
class HitTrain:
    """Impulses ``impulses_ns`` (K,) at ``times_s`` (K,), all at one ``point`` along one
    ``direction`` (None = the surface normal there), each a half-sine pulse ``duration_s``
    long: the same as K :class:`ModalHit` of those values (:meth:`hits`), in that order."""

    times_s: np.ndarray
    point: np.ndarray
    impulses_ns: np.ndarray
    duration_s: float
    direction: np.ndarray | None = None

    def __post_init__(self) -> None:
        if np.shape(self.times_s) != np.shape(self.impulses_ns) or np.ndim(self.times_s) != 1:
            raise ValueError(f"a hit train needs one impulse per time: {np.shape(self.times_s)}"
                             f" times, {np.shape(self.impulses_ns)} impulses")

    def hits(self) -> list[ModalHit]:
        return [ModalHit(float(t), self.point, float(j), self.duration_s, self.direction)
                for t, j in zip(self.times_s, self.impulses_ns)]

    def force_pulses(self) -> tuple[tuple[float, float, float], ...]:
        """(start (s), impulse (N s), duration (s)) of each half-sine pulse of the force."""
        return tuple((float(t), float(j), self.duration_s)
                     for t, j in zip(self.times_s, self.impulses_ns))


Hit = ModalHit | HitTrain


def _sample(times_s, sample_rate: int) -> np.ndarray:
    """The sample of each time, rounded half to even (as Python's ``round``)."""
    return np.rint(np.asarray(times_s, float) * float(sample_rate)).astype(np.int64)


def pulse_table(hits: Sequence[Hit], n_out: int, sample_rate: int
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Every force pulse of ``hits`` that pushes (impulse > 0) and starts within ``n_out``
    samples, in the hits' order: (start sample, impulse (N s), duration (s)) arrays."""
    starts, impulses, durations = [], [], []
    for h in hits:
        if isinstance(h, HitTrain):
            t = np.asarray(h.times_s, float)
            j = np.asarray(h.impulses_ns, float)
            d = np.full(len(t), float(h.duration_s))
        else:
            p = h.force_pulses()
            t, j, d = (np.array([x[k] for x in p], float) for k in range(3))
        i0 = _sample(t, sample_rate)
        ok = (j > 0) & (i0 < n_out)
        starts.append(i0[ok])
        impulses.append(j[ok])
        durations.append(d[ok])
    if not starts:
        return np.zeros(0, np.int64), np.zeros(0), np.zeros(0)
    return np.concatenate(starts), np.concatenate(impulses), np.concatenate(durations)


@dataclass(frozen=True)
class ImpulseTable:
    """The impulses of a body's hits that the modes hear, in the hits' order: ``sample`` (H,)
    where each starts the modes ringing, ``impulse`` (H,), ``item`` (H,) which of ``items``
    (the hits that have any) it comes from; per item, its pulses' ``duration`` (I,) and the
    ``start`` (I,) of its impulses in the table."""

    sample: np.ndarray
    impulse: np.ndarray
    item: np.ndarray
    items: tuple[Hit, ...]
    duration: np.ndarray
    start: np.ndarray


def impulse_table(hits: Sequence[Hit], n_out: int, sample_rate: int) -> ImpulseTable:
    """The impulses of ``hits`` that push (> 0) and come within ``n_out`` samples; an impact
    that left the modes a state (``modal_state``) starts them ringing where the bodies part."""
    sample, impulse, items, duration, start = [], [], [], [], []
    rows = 0
    for h in hits:
        if isinstance(h, HitTrain):
            j = np.asarray(h.impulses_ns, float)
            at = _sample(h.times_s, sample_rate)
            ok = (j > 0) & (at < n_out)
            if not ok.any():
                continue
            at, j = at[ok], j[ok]
        else:
            if not (h.impulse_ns > 0 and int(round(h.time_s * sample_rate)) < n_out):
                continue
            at = np.array([int(round((h.time_s + (h.modal_state[2] if h.modal_state else 0.0))
                                     * sample_rate))])
            j = np.array([h.impulse_ns], float)
        sample.append(at)
        impulse.append(j)
        items.append(h)
        duration.append(float(h.duration_s))
        start.append(rows)
        rows += len(j)
    if not items:
        e = np.zeros(0)
        return ImpulseTable(e.astype(np.int64), e, e.astype(np.int64), (), e,
                            e.astype(np.int64))
    start_ = np.array(start, np.int64)
    item = np.repeat(np.arange(len(items)), np.diff(np.append(start_, rows)))
    return ImpulseTable(np.concatenate(sample), np.concatenate(impulse), item, tuple(items),
                        np.array(duration, float), start_)
