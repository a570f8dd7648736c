"""An impact as a contact between vibrating bodies: how much of it goes into their modes.

A prescribed force pulse (the rigid-body impulse J over the rigid Hertz time) hands each
mass-normalised mode the energy (phi_i . n J)^2 / 2 whatever the struck wall can take: for a
thin sheet (a toaster's 0.8 mm steel panel), whose local modal mass at the contact is a fraction
of the body's, the sum over modes exceeds the impact's whole kinetic energy, and grows without
bound as modes are added. The wall yields under the contact; the force is smaller and lasts
longer than against a rigid wall.

Here the impactor (effective mass m*, approach speed v) meets the bodies' modes through the
contact spring (Chaigne & Doutaut 1997, "Numerical simulations of xylophones. I.", the mallet
model, linearised): with compression delta = x - sum_bodies sum_i b_i q_i (b_i = phi_i . d at the
contact, d the direction the force pushes that body),

    m* x'' = -k delta,    q_i'' + omega_i^2 q_i = b_i k delta,

while delta > 0. The linear spring k = m* (pi / t_c)^2 lasts the rigid pair's Hertz time t_c.
The system is linear, so it is solved exactly by its normal modes (one small symmetric
eigenproblem per impact); the bodies part at the first return of delta to 0, and each mode keeps
its displacement and velocity from then on. Energy is conserved exactly: what the modes take is
what the rebound lacks, never more than m* v^2 / 2. Damping during the contact (milliseconds) is
neglected; a later contact does not see the ringing of an earlier one.

A wall that yields can leave the impactor and meet it again while it rings (a slender body
struck near its tip, a thin panel): the bodies chatter, touching for short intervals between
flights, as steel bars dropped at an angle onto a large surface do (Stoianovici & Hurmuzlu
1996, "A critical study of the applicability of rigid-body collision theory", J. Appl. Mech.
63(2): the contacts counted electrically; the bar's vibrations and its repeated impacts set
its rebound). Each contact interval is kept (when it starts, how long it lasts, the impulse it
delivers): the force is a train of those pulses, not one pulse spread over the time to the last
parting, which is mostly flight.

Each phase ends at its compression's (or gap's) first zero, found on a grid then refined
(:mod:`fallgen.audio.coupling_kernel`, compiled). A long chatter is chaotic: two correct
solvers that differ in the last bits of a crossing time can end 20 contacts later with
velocities ~1e-3 apart (relative), far below what is heard.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from fallgen.audio.coupling_kernel import phases

#: Samples per period of the fastest normal mode when searching the separation.
_PER_PERIOD = 6
#: Grid points per rigid contact time (at least).
_PER_CONTACT = 32
#: Longest contact searched, in rigid contact times (a very soft wall holds the impactor long).
_MAX_CONTACTS = 60.0
#: Contacts and flights followed at most (a wall that chatters against the impactor).
_MAX_PHASES = 41


def ringing_gains(q0: np.ndarray, v0: np.ndarray, omega_d: np.ndarray, decay: np.ndarray
                  ) -> np.ndarray:
    """Complex gains G of modes ringing freely from displacements ``q0`` and velocities
    ``v0``: q(t) = Im(G e^((-d + i w_d) t)) / w_d (:func:`fallgen.audio.impact.modal_sum`'s
    form), so G = v0 + d q0 + i w_d q0."""
    return (v0 + decay * q0) + 1j * omega_d * q0


@dataclass(frozen=True)
class CoupledImpact:
    """Each body's modal displacements and velocities when the bodies part for good
    (``displacement``, ``velocity``: one (n_i,) array per body, in the order given), how long
    they touched (``duration_s``: the sum of the contact intervals), the impactor's rebound
    speed (relative, along the approach: negative is away), the energies (incoming m* v^2 / 2,
    taken by the modes), each contact interval (``contacts``: (start s, length s, impulse N s),
    the impulse m* times the change of the impactor's speed over it) and when the bodies part
    for good (``parting_s``: the last interval's end, flights included)."""

    displacement: tuple[np.ndarray, ...]
    velocity: tuple[np.ndarray, ...]
    duration_s: float
    rebound_mps: float
    incoming_j: float
    vibration_j: float
    contacts: tuple[tuple[float, float, float], ...] = ()
    parting_s: float = 0.0

    def gains(self, body: int, omega_d: np.ndarray, decay: np.ndarray) -> np.ndarray:
        """Complex gains of one body's modes for free ringing from the parting
        (:func:`ringing_gains`)."""
        return ringing_gains(self.displacement[body], self.velocity[body], omega_d, decay)

    def scaled(self, factor: float) -> CoupledImpact:
        """The same parting with every modal amplitude times ``factor`` (energy factor^2)."""
        return CoupledImpact(tuple(q * factor for q in self.displacement),
                             tuple(v * factor for v in self.velocity), self.duration_s,
                             self.rebound_mps, self.incoming_j,
                             self.vibration_j * factor * factor, self.contacts, self.parting_s)


def coupled_impact(mass_kg: float, speed_mps: float, contact_time_s: float,
                   bodies: Sequence[tuple[np.ndarray, np.ndarray]]) -> CoupledImpact:
    """The impact of an effective mass ``mass_kg`` at ``speed_mps`` through a contact spring
    that alone would last ``contact_time_s`` (the rigid Hertz time) on ``bodies``: for each,
    (omega (n,) rad/s, b (n,) the mass-normalised mode shapes at the contact along the force
    on that body, 1/sqrt(kg))."""
    if mass_kg <= 0 or speed_mps <= 0 or contact_time_s <= 0:
        raise ValueError("mass, speed and contact time must be positive")
    omega = np.concatenate([np.asarray(w, float) for w, _ in bodies]) if bodies else np.zeros(0)
    b = np.concatenate([np.asarray(bb, float) for _, bb in bodies]) if bodies else np.zeros(0)
    if omega.shape != b.shape:
        raise ValueError("each body needs as many mode shapes as frequencies")
    k = mass_kg * (math.pi / contact_time_s) ** 2
    # mass-weighted coordinates z = M^(1/2) y, y = (x, q...): K_z = S K S, S = M^(-1/2)
    sm = math.sqrt(mass_kg)
    s = np.concatenate([[1.0 / sm], np.ones(len(omega))])
    u = np.concatenate([[1.0], -b]) * s  # delta = u . z
    Kz = k * np.outer(u, u)
    Kz[np.arange(1, len(s)), np.arange(1, len(s))] += omega ** 2
    lam, phi = np.linalg.eigh(Kz)
    Om = np.maximum(np.sqrt(np.maximum(lam, 0.0)), 1e-9)
    uphi = u @ phi
    tc = contact_time_s
    fastest = max(float(Om.max()), float(omega.max()) if len(omega) else 0.0)
    dt = min(tc / _PER_CONTACT, 2 * math.pi / fastest / _PER_PERIOD)
    q, qd, xd, intervals, t_last = phases(
        float(mass_kg), float(speed_mps), sm, omega, b, np.ascontiguousarray(phi), Om,
        np.ascontiguousarray(uphi), dt, _MAX_CONTACTS * tc, _MAX_PHASES)
    contacts = tuple(tuple(map(float, row)) for row in intervals)
    vib = 0.5 * float(np.sum(qd * qd + (omega * q) ** 2))
    splits = np.cumsum([len(np.asarray(w_)) for w_, _ in bodies])[:-1]
    return CoupledImpact(tuple(np.split(q, splits)), tuple(np.split(qd, splits)),
                         float(sum(c[1] for c in contacts)), float(xd),
                         0.5 * mass_kg * speed_mps ** 2, vib, contacts, float(t_last))

