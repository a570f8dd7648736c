"""The compiled phases of :func:`fallgen.audio.coupling.coupled_impact`: contacts and flights
followed from the coupled system's normal modes until the bodies part for good.

Each phase's compression (or gap) is f(t) = c0 + c1 t + sum_j a_j cos(w_j t) + b_j sin(w_j t);
it ends at f's first zero after 0. The zero is bracketed on a grid of step ``dt`` (each mode's
phasor (a_j - i b_j) e^(i w_j t) taken from one grid point to the next by one complex product,
set exactly from ``exp`` at the start of each chunk of 32, 128, 512, then 2048 points, so that
rounding never accumulates over more than 2048 products), then refined by Brent's method (the
algorithm of SciPy's ``brentq``, its C code written out) on f evaluated from ``cos`` and ``sin``.
"""

from __future__ import annotations

import cmath
import math

import numpy as np
from numba import njit

#: Brent's method: the most iterations (SciPy's default).
_BRENT_ITER = 100


@njit(cache=True)
def _value(c0: float, c1: float, w, a, b, sign: float, t: float) -> float:
    """sign * f(t), f as the module's doc writes it."""
    ca = 0.0
    for j in range(len(w)):
        ca += a[j] * math.cos(w[j] * t)
    sb = 0.0
    for j in range(len(w)):
        sb += b[j] * math.sin(w[j] * t)
    return sign * (c0 + c1 * t + ca + sb)


@njit(cache=True)
def _brent(c0, c1, w, a, b, sign, xa, xb, xtol, rtol):
    """A zero of sign * f in [xa, xb] (signs differ at the ends): SciPy's ``brentq``."""
    xpre, xcur = xa, xb
    xblk, fblk, spre, scur = 0.0, 0.0, 0.0, 0.0
    fpre = _value(c0, c1, w, a, b, sign, xpre)
    fcur = _value(c0, c1, w, a, b, sign, xcur)
    if fpre == 0.0:
        return xpre
    if fcur == 0.0:
        return xcur
    for _ in range(_BRENT_ITER):
        if fpre != 0.0 and fcur != 0.0 and (fpre < 0.0) != (fcur < 0.0):
            xblk, fblk = xpre, fpre
            spre = scur = xcur - xpre
        if abs(fblk) < abs(fcur):
            xpre, xcur, xblk = xcur, xblk, xcur
            fpre, fcur, fblk = fcur, fblk, fcur
        delta = (xtol + rtol * abs(xcur)) / 2
        sbis = (xblk - xcur) / 2
        if fcur == 0.0 or abs(sbis) < delta:
            return xcur
        if abs(spre) > delta and abs(fcur) < abs(fpre):
            if xpre == xblk:  # interpolate
                stry = -fcur * (xcur - xpre) / (fcur - fpre)
            else:  # extrapolate
                dpre = (fpre - fcur) / (xpre - xcur)
                dblk = (fblk - fcur) / (xblk - xcur)
                stry = -fcur * (fblk * dblk - fpre * dpre) / (dblk * dpre * (fblk - fpre))
            if 2 * abs(stry) < min(abs(spre), 3 * abs(sbis) - delta):  # a good short step
                spre, scur = scur, stry
            else:
                spre, scur = sbis, sbis
        else:
            spre, scur = sbis, sbis
        xpre, fpre = xcur, fcur
        if abs(scur) > delta:
            xcur += scur
        else:
            xcur += delta if sbis > 0 else -delta
        fcur = _value(c0, c1, w, a, b, sign, xcur)
    return xcur


@njit(cache=True)
def first_crossing(c0, c1, w, a, b, sign, dt, horizon):
    """The first t in (0, ``horizon``] where sign * f(t) <= 0 (> 0 just after 0), to ~1e-9 of
    a step; -1 when there is none."""
    m = len(w)
    step = np.empty(m, np.complex128)
    ph = np.empty(m, np.complex128)
    for j in range(m):
        step[j] = cmath.exp(1j * (w[j] * dt))
    t0, size = dt, 32
    while t0 <= horizon:
        n = min(size, int(math.floor((horizon + dt - t0) / dt + 1e-9)) + 1)
        for j in range(m):
            ph[j] = complex(a[j], -b[j]) * cmath.exp(1j * (w[j] * t0))
        for i in range(n):
            t = t0 + dt * i
            waves = 0.0
            for j in range(m):
                waves += ph[j].real
                ph[j] *= step[j]
            d = sign * (c0 + c1 * t + waves)
            if d <= 0.0:
                lo, hi = t0 + dt * (i - 1), t
                if d == 0.0:
                    return hi
                if _value(c0, c1, w, a, b, sign, lo) <= 0.0:  # within the first step: bisect
                    for _ in range(30):
                        mid = 0.5 * (lo + hi)
                        if _value(c0, c1, w, a, b, sign, mid) > 0.0:
                            lo = mid
                        else:
                            hi = mid
                    if _value(c0, c1, w, a, b, sign, lo) <= 0.0:
                        return hi
                return _brent(c0, c1, w, a, b, sign, lo, hi, dt * 1e-9,
                              4 * 2.220446049250313e-16)
        t0 = (t0 + dt * (n - 1)) + dt
        size = min(4 * size, 2048)
    return -1.0


@njit(cache=True)
def _times(m, u, v, mu, mv, transposed):
    """``mu`` = M ``u``, ``mv`` = M ``v`` (M^T with ``transposed``), each sum in index order."""
    n = m.shape[0]
    for i in range(n):
        su = 0.0
        sv = 0.0
        for r in range(n):
            w = m[r, i] if transposed else m[i, r]
            su += w * u[r]
            sv += w * v[r]
        mu[i], mv[i] = su, sv


@njit(cache=True)
def phases(mass_kg, speed_mps, sm, omega, b, phi, om, uphi, dt, t_end, max_phases):
    """Follow the contact from its first touch: (q, qd) the modes' displacements and
    velocities at the final parting, the impactor's relative speed then, the contact
    intervals (P, 3: start s, length s, impulse N s; P <= ``max_phases``) and the last
    parting's time. ``phi``, ``om``: the coupled system's mass-weighted normal modes and
    frequencies; ``uphi``: the compression's weight on each; ``sm``: sqrt(``mass_kg``)."""
    n = len(omega)
    wq = np.maximum(omega, 1e-9)
    x, xd = 0.0, speed_mps
    q, qd = np.zeros(n), np.zeros(n)
    t_now, touching, t_last = 0.0, True, 0.0
    contacts = np.zeros((max_phases, 3))
    nc = 0
    na = n + 1
    y0, y1 = np.empty(na), np.empty(na)
    al, be = np.empty(na), np.empty(na)
    a, bb = np.empty(na), np.empty(na)
    for _ in range(max_phases):
        reach = 0.0
        if touching:  # in contact: the coupled system's normal modes
            y0[0], y1[0] = sm * x, sm * xd
            y0[1:], y1[1:] = q, qd
            _times(phi, y0, y1, al, be, True)  # the normal coordinates and velocities
            for i in range(na):
                be[i] /= om[i]
                a[i], bb[i] = uphi[i] * al[i], uphi[i] * be[i]
            t_cross = first_crossing(0.0, 0.0, om, a, bb, 1.0, dt, t_end - t_now)
            if t_cross < 0.0:  # held to the end of the search: part there
                t_cross = t_end - t_now
            ys, yv = np.empty(na), np.empty(na)
            for i in range(na):
                c, sn = math.cos(om[i] * t_cross), math.sin(om[i] * t_cross)
                ys[i] = al[i] * c + be[i] * sn
                yv[i] = (-al[i] * sn + be[i] * c) * om[i]
            z, zd = np.empty(na), np.empty(na)
            _times(phi, ys, yv, z, zd, False)
            xd_in = xd
            x, xd = z[0] / sm, zd[0] / sm
            q, qd = z[1:].copy(), zd[1:].copy()
            t_last = t_now + t_cross
            contacts[nc, 0], contacts[nc, 1] = t_now, t_cross
            contacts[nc, 2] = mass_kg * (xd_in - xd)
            nc += 1
        else:  # apart: the impactor flies, each mode rings on its own
            for i in range(n):
                reach += abs(b[i]) * math.hypot(q[i], qd[i] / wq[i])
            if xd < 0 and x < -reach:
                break  # moving away beyond any wall motion: no further contact
            horizon = t_end - t_now
            if xd < 0:  # past this it is beyond any wall motion
                horizon = min(horizon, (x + reach) / -xd)
            t_cross = first_crossing(x, xd, wq, -b * q, -b * qd / wq, -1.0, dt, horizon)
            if t_cross < 0.0:
                break
            c, sn = np.cos(wq * t_cross), np.sin(wq * t_cross)
            x = x + xd * t_cross
            q, qd = q * c + qd / wq * sn, -q * wq * sn + qd * c
        t_now += t_cross
        touching = not touching
        if t_now >= t_end:
            break
    return q, qd, xd, contacts[:nc].copy(), t_last
