"""Calibrating MuJoCo's soft contacts against restitution.

MuJoCo has no coefficient of restitution: a contact is a soft constraint with a reference
spring-damper, ``solref = [timeconst, dampratio]``, and how much a body bounces follows from that
pair *and* from the discrete time step (at fallgen's 2 ms a short time constant with a low
damping ratio gains energy). So each material's ``solref`` is fitted, by simulation, to its
published coefficient of restitution: :func:`bounce` drops a sphere onto a heavy slab and
measures e = -v_out / v_in and the deepest penetration; :func:`fit_solref` searches a ladder of
time constants and damping ratios for the stiffest stable pair that gives the wanted e.

Two geoms in contact mix their ``solref`` with weights ``solmix`` (MuJoCo); fallgen sets a geom's
``solmix`` to its material's compliance (1 / Young's modulus), so the softer body of a pair sets
the bounce, as it does physically (it stores most of the impact energy).
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from fallgen.world.scene import CONTACT_SOLIMP

#: Time constants tried by :func:`fit_solref`, shortest (stiffest) first.
TIMECONST_LADDER_S = (0.006, 0.008, 0.01, 0.015, 0.02, 0.03)
#: Impact speeds (m/s) a fit must behave at: a gentle bounce, a typical one, a 2.8 m drop.
FIT_SPEEDS_MPS = (1.0, 2.5, 7.5)


@dataclass(frozen=True)
class Bounce:
    restitution: float  # -v_out / v_in of the body's centre (0 when it does not leave)
    penetration_m: float  # deepest penetration during the impact


def bounce(solref_body: tuple[float, float], solref_slab: tuple[float, float], speed_mps: float,
           *, mix: tuple[float, float] = (1.0, 1.0), timestep: float = 0.002,
           radius_m: float = 0.02, mass_kg: float = 0.05) -> Bounce:
    """Drop a sphere at ``speed_mps`` straight onto a 10 cm slab (fallgen's contact settings:
    implicitfast, elliptic cones, impratio 10, condim 6, zero margin, CONTACT_SOLIMP) and measure the bounce."""
    (t1, z1), (t2, z2) = solref_body, solref_slab
    imp = " ".join(repr(x) for x in CONTACT_SOLIMP)
    xml = f"""<mujoco><option timestep="{timestep}" integrator="implicitfast" cone="elliptic"
      impratio="10"/><worldbody>
      <geom type="box" size="1 1 .05" pos="0 0 -.05" solref="{t2!r} {z2!r}" solmix="{mix[1]!r}"
        solimp="{imp}" margin="0"/>
      <body pos="0 0 {radius_m + 1e-4!r}"><freejoint/><geom type="sphere" size="{radius_m!r}"
        mass="{mass_kg!r}" solref="{t1!r} {z1!r}" solmix="{mix[0]!r}" solimp="{imp}" condim="6"
        margin="0"/>
      </body></worldbody></mujoco>"""
    m = mujoco.MjModel.from_xml_string(xml)
    d = mujoco.MjData(m)
    d.qvel[2] = -speed_mps
    lowest, touched = 0.0, False
    for _ in range(int(0.5 / timestep)):
        mujoco.mj_step(m, d)
        lowest = min(lowest, float(d.qpos[2]) - radius_m)
        touched |= d.ncon > 0
        if touched and d.ncon == 0:
            break
    return Bounce(max(float(d.qvel[2]) / speed_mps, 0.0), -lowest)


@dataclass(frozen=True)
class SolrefFit:
    solref: tuple[float, float]
    restitution: tuple[float, ...]  # at FIT_SPEEDS_MPS
    penetration_m: float  # at the fastest speed


def fit_solref(restitution: float, *, timestep: float = 0.002, tol: float = 0.03,
               max_penetration_m: float = 0.025) -> SolrefFit:
    """The stiffest (shortest time constant) ``solref`` whose same-material bounce at 2.5 m/s is
    within ``tol`` of ``restitution``, that never gains energy at the fit speeds, that sits on a
    smooth part of the e(dampratio) curve (no cliff within +-0.05) and penetrates at most
    ``max_penetration_m`` at 7.5 m/s."""
    zetas = np.round(np.arange(0.05, 1.501, 0.01), 3)
    for tc in TIMECONST_LADDER_S:
        best = None
        for z in zetas:
            ref = (tc, float(z))
            mid = bounce(ref, ref, FIT_SPEEDS_MPS[1], timestep=timestep)
            if abs(mid.restitution - restitution) > tol:
                continue
            runs = [mid if v == FIT_SPEEDS_MPS[1] else bounce(ref, ref, v, timestep=timestep)
                    for v in FIT_SPEEDS_MPS]
            es = tuple(r.restitution for r in runs)
            pen = runs[-1].penetration_m
            near = [bounce((tc, float(z) + dz), (tc, float(z) + dz), FIT_SPEEDS_MPS[1],
                           timestep=timestep).restitution for dz in (-0.05, 0.05)]
            if max(es) >= 0.95 or pen > max_penetration_m or abs(near[0] - near[1]) > 0.3:
                continue
            cand = SolrefFit(ref, es, pen)
            if best is None or abs(es[1] - restitution) < abs(best.restitution[1] - restitution):
                best = cand
        if best is not None:
            return best
    raise ValueError(f"no stable solref gives restitution {restitution} at timestep {timestep}")
