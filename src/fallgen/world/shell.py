"""Thin-walled bodies: a shape's sheet walls, described for its vibration model.

A wall far thinner than a voxel (a drink can's 0.12 mm aluminium, a toaster's 0.8 mm steel) cannot
be resolved by the voxel finite elements: one voxel layer can have the wall's bending stiffness
or its membrane stiffness, not both, and a shell's low modes need both. Such shapes carry a
:class:`ThinShell`, an idealised sheet body (a cylinder with stiff ends, or a box of panels) whose
modes are computed by thin-shell theory (:mod:`fallgen.audio.shells`) instead.
"""

from __future__ import annotations

from dataclasses import dataclass

#: Walls up to this thick are modelled as thin shells.
THIN_WALL_M = 0.001


@dataclass(frozen=True)
class ThinShell:
    """``kind`` "cylinder": a wall of ``radius`` and ``length`` (axis z) whose ends are held
    round by stiff end pieces (lids, seams, a base); "box": six panels of a box with sides
    ``size``, each held flat at its edges. Both ``thickness`` thick, centred at ``center`` in
    the shape's frame."""

    kind: str
    size: tuple[float, float, float]  # cylinder: (radius, radius, length); box: (lx, ly, lz)
    thickness: float
    center: tuple[float, float, float] = (0.0, 0.0, 0.0)

    def __post_init__(self) -> None:
        if self.kind not in ("cylinder", "box"):
            raise ValueError(f"ThinShell kind must be 'cylinder' or 'box', not {self.kind!r}")
        if self.thickness <= 0 or min(self.size) <= self.thickness:
            raise ValueError("ThinShell needs 0 < thickness < every size")

    @staticmethod
    def cylinder(radius: float, length: float, thickness: float,
                 center: tuple[float, float, float] = (0.0, 0.0, 0.0)) -> ThinShell:
        return ThinShell("cylinder", (radius, radius, length), thickness, center)

    def shifted(self, offset) -> ThinShell:
        """The same shell with its centre moved by ``offset``."""
        c = tuple(float(a + b) for a, b in zip(self.center, offset))
        return ThinShell(self.kind, self.size, self.thickness, c)
