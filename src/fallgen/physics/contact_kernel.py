"""The compiled core of :class:`~fallgen.physics.contacts.ContactRecorder`: steps a MuJoCo
simulation and turns the falling body's contacts into events as it goes.

:func:`run` calls ``mj_step`` itself and reads ``mjData`` through :mod:`fallgen.physics.mjraw`,
so a recorded step costs what ``mj_step`` costs. Every quantity is computed with the same IEEE
operations in the same order as the rules in :mod:`fallgen.physics.contacts` state them
(Numba contracts no multiply-adds; ``max`` and ``min`` are written out as Python evaluates
them, which matters for the sign of a zero): the events do not depend on how many steps one
call makes.

State lives in arrays the caller owns: one open contact episode per other geom (indexed by its
id; the order they opened in, which is the order they close in when several go stale at once),
and the events made so far, each tagged with its episode's serial number and its place in it, so
the caller can list them in the order the rules make them.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from fallgen.physics.mjraw import call_step, load_f64, load_i32, load_i64

# -- ContactParams, packed (see contacts.ContactParams) ------------------------------------------
P_IMPACT, P_SLIP, P_ROLL, P_GAP, P_REST, P_MAXCOMP, P_HOPGAP, P_HOPMU, P_IMPCONTACT, P_DT, \
    P_SAMPLE = range(11)
# -- run state (ints) ----------------------------------------------------------------------------
S_STEP, S_NEVENTS, S_NSERIAL, S_NCLOSED, S_NOPEN = range(5)
# -- sweep (floats): the body origin's lowest and highest x, y over the start and every step
W_XLO, W_XHI, W_YLO, W_YHI = range(4)
# -- episode ints, per other geom
E_OPEN, E_START, E_GOBJ, E_COMP, E_NCOMP, E_HOP, E_SEEN, E_SSTEPS, E_SSTART_OK, E_SSTART_STEP, \
    E_SERIAL, E_HAS_LAST, E_LAST = range(13)
N_EI = 13
# -- episode floats, per other geom (3-vectors take 3 slots)
F_PW, F_PO, F_N = 0, 3, 6
F_APPROACH, F_IMPULSE, F_VNLAST, F_SFORCE, F_SSLIP, F_SVN = range(9, 15)
F_SSTART, F_SPOINT, F_SPOINT_OBJ = 15, 18, 21
N_EF = 24
# -- events: floats and ints
V_TIME, V_PW, V_PO, V_N = 0, 1, 4, 7
V_NSPEED, V_IMPULSE, V_SLIP, V_DUR, V_FORCE, V_TRAVEL = range(10, 16)
N_VF = 16
K_KIND, K_GOBJ, K_GOTHER, K_SERIAL, K_SUB = range(5)
N_VI = 5
IMPACT, SCRAPE, ROLL = 0, 1, 2  # indices in contacts.KINDS
# -- mjraw.Layout.as_array()
L_NCON, L_CONTACT, L_EFC_FORCE, L_SIZE, L_POS, L_FRAME, L_DIM, L_GEOM, L_EFC_ADR = range(9)


@njit(cache=True)
def _emit(kind, other, sub, time, point, normal, nspeed, impulse, slip, dur, force, pobj,
          travel, ei, ef, st, vf, vi):
    k = st[S_NEVENTS]
    st[S_NEVENTS] = k + 1
    vf[k, V_TIME] = time
    for j in range(3):
        vf[k, V_PW + j] = point[j]
        vf[k, V_PO + j] = pobj[j]
        vf[k, V_N + j] = normal[j]
    vf[k, V_NSPEED] = nspeed
    vf[k, V_IMPULSE] = impulse
    vf[k, V_SLIP] = slip
    vf[k, V_DUR] = dur
    vf[k, V_FORCE] = force
    vf[k, V_TRAVEL] = travel
    vi[k, K_KIND] = kind
    vi[k, K_GOBJ] = ei[other, E_GOBJ]
    vi[k, K_GOTHER] = other
    vi[k, K_SERIAL] = ei[other, E_SERIAL]
    vi[k, K_SUB] = sub


@njit(cache=True)
def _flush(other, n, P, ei, ef, st, vf, vi):
    """Close the current sample of ``other``'s episode (a scrape or roll event, if it was)."""
    s = ei[other, E_SSTEPS]
    if s == 0:
        return
    dt = P[P_DT]
    dur = s * dt
    slip = ef[other, F_SSLIP] / s
    r0 = ef[other, F_SPOINT] - ef[other, F_SSTART]
    r1 = ef[other, F_SPOINT + 1] - ef[other, F_SSTART + 1]
    r2 = ef[other, F_SPOINT + 2] - ef[other, F_SSTART + 2]
    travel = math.sqrt(r0 * r0 + r1 * r1 + r2 * r2) / dur
    kind = SCRAPE if slip >= P[P_SLIP] else (ROLL if travel >= P[P_ROLL] else -1)
    if kind >= 0:
        f = ef[other, F_SFORCE]
        _emit(kind, other, 1 + st[S_NEVENTS], (ei[other, E_SSTART_STEP] - 1) * dt,
              ef[other, F_SPOINT:F_SPOINT + 3], n, ef[other, F_SVN] / s, f * dt, slip, dur,
              f / s, ef[other, F_SPOINT_OBJ:F_SPOINT_OBJ + 3], travel, ei, ef, st, vf, vi)
    ei[other, E_SSTEPS] = 0
    ef[other, F_SFORCE] = 0.0
    ef[other, F_SSLIP] = 0.0
    ef[other, F_SVN] = 0.0
    ei[other, E_SSTART_OK] = 0
    ei[other, E_SSTART_STEP] = st[S_STEP] + 1


@njit(cache=True)
def _close(slot, P, ei, ef, st, vf, vi, order, rank):
    """Close the open episode at ``order[slot]``: its last sample, then its impact."""
    other = order[slot]
    for j in range(slot, st[S_NOPEN] - 1):
        order[j] = order[j + 1]
    st[S_NOPEN] -= 1
    ei[other, E_OPEN] = 0
    _flush(other, ef[other, F_N:F_N + 3], P, ei, ef, st, vf, vi)
    ei[other, E_HAS_LAST] = 1
    ei[other, E_LAST] = ei[other, E_SEEN]
    if ef[other, F_APPROACH] >= P[P_IMPACT] and ei[other, E_HOP] == 0:
        dur = ei[other, E_NCOMP] * P[P_DT]
        imp = ef[other, F_IMPULSE]
        _emit(IMPACT, other, 0, (ei[other, E_START] - 1) * P[P_DT], ef[other, F_PW:F_PW + 3],
              ef[other, F_N:F_N + 3], ef[other, F_APPROACH], imp, 0.0, dur,
              imp / dur if dur > 0 else 0.0, ef[other, F_PO:F_PO + 3], 0.0, ei, ef, st, vf, vi)
    rank[ei[other, E_SERIAL]] = st[S_NCLOSED]
    st[S_NCLOSED] += 1


@njit(cache=True)
def _close_stale(P, ei, ef, st, vf, vi, order, rank):
    gap = int(P[P_GAP])
    slot = 0
    while slot < st[S_NOPEN]:
        if st[S_STEP] - ei[order[slot], E_SEEN] >= gap:
            _close(slot, P, ei, ef, st, vf, vi, order, rank)
        else:
            slot += 1


@njit(cache=True)
def finish(P, ei, ef, st, vf, vi, order, rank):
    """Close every open episode, oldest first."""
    while st[S_NOPEN] > 0:
        _close(0, P, ei, ef, st, vf, vi, order, rank)


@njit(cache=True)
def run(step_fn, m_addr, d_addr, nsteps, body, bodyid, friction, pyramidal, lay, qvel, xmat,
        xpos, qpos, P, st, sw, ei, ef, vf, vi, order, rank):
    """Step ``nsteps`` times (fewer when the event arrays may fill: the steps made are
    returned, and the caller grows them), recording the contacts of body ``body``."""
    dt = P[P_DT]
    ngeom = len(bodyid)
    pv = np.empty(6)
    pm = np.empty(9)
    px = np.empty(3)
    # this step's contacts per other geom, in order of first appearance
    g_other = np.empty(64, np.int64)
    g_mine = np.empty(64, np.int64)
    g_f = np.empty((64, 7))  # pos, normal (from the other toward the body), force
    slot_of = np.full(ngeom, -1, np.int64)
    done = 0
    while done < nsteps:
        if st[S_NEVENTS] + 2 * ngeom > len(vf) or st[S_NSERIAL] + ngeom > len(rank):
            return done
        # the state before the step
        for j in range(6):
            pv[j] = qvel[j]
        for j in range(9):
            pm[j] = xmat[j]
        for j in range(3):
            px[j] = xpos[j]
        call_step(step_fn, m_addr, d_addr)
        done += 1
        st[S_STEP] += 1
        step = st[S_STEP]
        x, y = qpos[0], qpos[1]
        if x < sw[W_XLO]:
            sw[W_XLO] = x
        elif x > sw[W_XHI]:
            sw[W_XHI] = x
        if y < sw[W_YLO]:
            sw[W_YLO] = y
        elif y > sw[W_YHI]:
            sw[W_YHI] = y
        ncon = load_i32(d_addr + lay[L_NCON])
        base = load_i64(d_addr + lay[L_CONTACT])
        size = lay[L_SIZE]
        if ncon > len(g_other):
            g_other = np.empty(ncon, np.int64)
            g_mine = np.empty(ncon, np.int64)
            g_f = np.empty((ncon, 7))
        ng = 0
        for i in range(ncon):
            c = base + i * size
            g1 = load_i32(c + lay[L_GEOM])
            g2 = load_i32(c + lay[L_GEOM] + 4)
            first_mine = bodyid[g1] == body
            if first_mine == (bodyid[g2] == body):
                continue
            if first_mine:
                mine, other, sign = g1, g2, -1.0
            else:
                mine, other, sign = g2, g1, 1.0
            # mj_contactForce's normal component (pyramidal cones: the sum of the edges)
            fn = 0.0
            adr = load_i32(c + lay[L_EFC_ADR])
            if adr >= 0:
                efc = load_i64(d_addr + lay[L_EFC_FORCE]) + 8 * adr
                dim = load_i32(c + lay[L_DIM])
                if pyramidal and dim > 1:
                    for j in range(2 * (dim - 1)):
                        fn += load_f64(efc + 8 * j)
                else:
                    fn = load_f64(efc)
            k = slot_of[other]
            if k >= 0:  # several contact points with one geom: forces summed
                g_f[k, 6] += fn
                continue
            k = ng
            ng += 1
            slot_of[other] = k
            g_other[k] = other
            g_mine[k] = mine
            for j in range(3):
                g_f[k, j] = load_f64(c + lay[L_POS] + 8 * j)
                g_f[k, 3 + j] = sign * load_f64(c + lay[L_FRAME] + 8 * j)
            g_f[k, 6] = fn
        if ng == 0:
            if st[S_NOPEN] > 0:
                _close_stale(P, ei, ef, st, vf, vi, order, rank)
            continue
        # the body's velocity after the step (world frame), where its frame was
        w0, w1, w2 = qvel[3], qvel[4], qvel[5]
        v0, v1, v2 = qvel[0], qvel[1], qvel[2]
        a0 = xmat[0] * w0 + xmat[1] * w1 + xmat[2] * w2
        a1 = xmat[3] * w0 + xmat[4] * w1 + xmat[5] * w2
        a2 = xmat[6] * w0 + xmat[7] * w1 + xmat[8] * w2
        for k in range(ng):
            other = g_other[k]
            slot_of[other] = -1
            p0, p1, p2 = g_f[k, 0], g_f[k, 1], g_f[k, 2]
            n0, n1, n2 = g_f[k, 3], g_f[k, 4], g_f[k, 5]
            fn = g_f[k, 6]
            r0, r1, r2 = p0 - xpos[0], p1 - xpos[1], p2 - xpos[2]
            u0 = v0 + (a1 * r2 - a2 * r1)
            u1 = v1 + (a2 * r0 - a0 * r2)
            u2 = v2 + (a0 * r1 - a1 * r0)
            vn = u0 * n0 + u1 * n1 + u2 * n2  # > 0 separating
            t0, t1, t2 = u0 - vn * n0, u1 - vn * n1, u2 - vn * n2
            slip = math.sqrt(t0 * t0 + t1 * t1 + t2 * t2)
            # the point in the body's frame
            b0 = xmat[0] * r0 + xmat[3] * r1 + xmat[6] * r2
            b1 = xmat[1] * r0 + xmat[4] * r1 + xmat[7] * r2
            b2 = xmat[2] * r0 + xmat[5] * r1 + xmat[8] * r2
            if ei[other, E_OPEN] == 0:
                # a new episode: the approach speed from the state before the step
                c0 = pm[0] * pv[3] + pm[1] * pv[4] + pm[2] * pv[5]
                c1 = pm[3] * pv[3] + pm[4] * pv[4] + pm[5] * pv[5]
                c2 = pm[6] * pv[3] + pm[7] * pv[4] + pm[8] * pv[5]
                q0, q1, q2 = p0 - px[0], p1 - px[1], p2 - px[2]
                e0 = pv[0] + (c1 * q2 - c2 * q1)
                e1 = pv[1] + (c2 * q0 - c0 * q2)
                e2 = pv[2] + (c0 * q1 - c1 * q0)
                vn0 = e0 * n0 + e1 * n1 + e2 * n2
                ei[other, E_OPEN] = 1
                ei[other, E_START] = step
                ei[other, E_GOBJ] = g_mine[k]
                ei[other, E_COMP] = 1
                ei[other, E_NCOMP] = 0
                ei[other, E_SSTEPS] = 0
                ei[other, E_SSTART_OK] = 1
                ei[other, E_SSTART_STEP] = step
                ei[other, E_SERIAL] = st[S_NSERIAL]
                st[S_NSERIAL] += 1
                for j in range(3):
                    ef[other, F_PW + j] = g_f[k, j]
                    ef[other, F_N + j] = g_f[k, 3 + j]
                    ef[other, F_SSTART + j] = g_f[k, j]
                ef[other, F_PO] = b0
                ef[other, F_PO + 1] = b1
                ef[other, F_PO + 2] = b2
                ef[other, F_APPROACH] = -vn0 if -vn0 > 0.0 else 0.0  # noqa: FURB136
                ef[other, F_IMPULSE] = 0.0
                ef[other, F_VNLAST] = vn0
                ef[other, F_SFORCE] = 0.0
                ef[other, F_SSLIP] = 0.0
                ef[other, F_SVN] = 0.0
                # a re-contact of a slide (see ContactParams) is not an impact
                hop = 0
                if ei[other, E_HAS_LAST] == 1 and not slip < P[P_SLIP]:
                    gap_s = (step - ei[other, E_LAST]) * dt
                    fa, fb = friction[g_mine[k]], friction[other]
                    mu = fb if fb > fa else fa  # noqa: FURB136
                    if gap_s <= P[P_HOPGAP] and ef[other, F_APPROACH] <= P[P_HOPMU] * mu * slip:
                        hop = 1
                ei[other, E_HOP] = hop
                order[st[S_NOPEN]] = other
                st[S_NOPEN] += 1
            ei[other, E_SEEN] = step
            if ei[other, E_COMP] == 1:
                ei[other, E_NCOMP] += 1
                last = ef[other, F_VNLAST]
                if vn >= -P[P_REST]:
                    # the approach ended during this step: only the share of its impulse that
                    # brought the normal velocity to zero (linear in the step)
                    if vn > last:
                        r = -last / (vn - last)
                        r = r if r > 0.0 else 0.0  # noqa: FURB136
                        frac = r if r < 1.0 else 1.0  # noqa: FURB136
                    else:
                        frac = 1.0
                    ef[other, F_IMPULSE] += frac * fn * dt
                    ei[other, E_COMP] = 0
                else:
                    ef[other, F_IMPULSE] += fn * dt
                    ei[other, E_COMP] = 1 if ei[other, E_NCOMP] * dt < P[P_MAXCOMP] else 0
                ef[other, F_VNLAST] = vn
            elif ef[other, F_APPROACH] >= P[P_IMPACT] and \
                    (step - ei[other, E_START] + 1) * dt <= P[P_IMPCONTACT]:
                ei[other, E_SSTART_OK] = 0  # the impact's own contact is not sampled
            else:
                ei[other, E_SSTEPS] += 1
                ef[other, F_SFORCE] += fn
                ef[other, F_SSLIP] += slip
                ef[other, F_SVN] += abs(vn)
                ef[other, F_SPOINT] = p0
                ef[other, F_SPOINT + 1] = p1
                ef[other, F_SPOINT + 2] = p2
                ef[other, F_SPOINT_OBJ] = b0
                ef[other, F_SPOINT_OBJ + 1] = b1
                ef[other, F_SPOINT_OBJ + 2] = b2
                if ei[other, E_SSTART_OK] == 0:
                    ei[other, E_SSTART_OK] = 1
                    ei[other, E_SSTART_STEP] = step
                    ef[other, F_SSTART] = p0
                    ef[other, F_SSTART + 1] = p1
                    ef[other, F_SSTART + 2] = p2
                if ei[other, E_SSTEPS] >= int(P[P_SAMPLE]):
                    _flush(other, g_f[k, 3:6], P, ei, ef, st, vf, vi)
        if st[S_NOPEN] > 0:
            _close_stale(P, ei, ef, st, vf, vi, order, rank)
    return done
