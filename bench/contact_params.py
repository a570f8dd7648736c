"""How MuJoCo 4.0's soft contact parameters map to bounce and penetration, for choosing
per-material ``solref``: a 20 mm sphere dropped on a slab at several speeds, for a grid of
(time constant, damping ratio, timestep). Prints one JSON line per setting:
coefficient of restitution e = -v_out / v_in and the deepest penetration (mm).

Findings on this machine (see the issue notes): at a 2 ms step, time constants below ~0.015 s
with damping ratios below ~0.3 gain energy (e > 1); above it e(zeta) follows roughly
0.75 / 0.58 / 0.45 / 0.25 / 0 for zeta 0.1 / 0.2 / 0.3 / 0.5 / 1, mildly speed dependent.
"""

from __future__ import annotations

import itertools
import json

import mujoco


def drop(tc: float, zeta: float, v0: float, dt: float, r: float = 0.02) -> tuple[float, float]:
    xml = f"""<mujoco><option timestep="{dt}" integrator="implicitfast" cone="elliptic"
    impratio="10"/><worldbody><geom type="box" size="1 1 .01" pos="0 0 -.01"
    solref="{tc} {zeta}"/><body pos="0 0 {r + 1e-4}"><freejoint/><geom type="sphere"
    size="{r}" mass="0.05" solref="{tc} {zeta}" condim="6"/></body></worldbody></mujoco>"""
    m = mujoco.MjModel.from_xml_string(xml)
    d = mujoco.MjData(m)
    d.qvel[2] = -v0
    lowest, touched = 0.0, False
    for _ in range(int(0.6 / dt)):
        mujoco.mj_step(m, d)
        lowest = min(lowest, d.qpos[2] - r)
        touched |= d.ncon > 0
        if touched and d.ncon == 0:
            break
    return d.qvel[2] / v0, -lowest * 1000


def main() -> None:
    for dt, tc, zeta in itertools.product((0.002, 0.001), (0.004, 0.01, 0.015, 0.02),
                                          (0.1, 0.2, 0.3, 0.5, 1.0)):
        res = {v0: drop(tc, zeta, v0, dt) for v0 in (1.0, 3.0, 5.0)}
        print(json.dumps({"dt": dt, "timeconst": tc, "dampratio": zeta,
                          "e": {str(v): round(e, 3) for v, (e, _) in res.items()},
                          "penetration_mm": {str(v): round(p, 1) for v, (_, p) in res.items()}}))


if __name__ == "__main__":
    main()
