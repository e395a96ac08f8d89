"""What a loop's shape means for its margins, said in notes: constant
levels, a Nyquist curve on the real axis, poles on the imaginary axis."""

from __future__ import annotations

import math

import numpy as np

from .detection import NOISE, Detection
from .loops import LoopModel


def shape_notes(loop: LoopModel, grid: Detection) -> list[str]:
    """What the loop's shape means for its margins: constant levels, a Nyquist
    curve on the real axis, poles on the imaginary axis."""
    notes = []
    if "1+GH" in grid.flat:
        notes.append(f"|1+GH| is constant ({abs(1 + grid.gh[0]):.6g}) at every frequency: "
                     "no interior minimum (no stability margin)")
    if "GH" in grid.flat:
        level = abs(grid.gh[0])
        notes.append(f"|GH| is constant ({level:.6g}) at every frequency"
                     + (": its crossing of 1 is not isolated (no phase margin)" if abs(level - 1) < 1e-9 else ""))
    if "phase" in grid.flat:
        notes.append(f"the phase of GH is constant ({math.degrees(np.angle(grid.gh[0])):.6g} deg)"
                     + (": on the negative real axis everywhere (gain crossings not isolated)"
                        if abs(abs(np.angle(grid.gh[0])) - math.pi) < 1e-9 else ""))
    elif _on_real_axis(grid):
        notes.append("GH is real at every frequency (the Nyquist curve lies on the real axis): its crossings "
                     "of the negative real axis are not isolated, so no gain margin is listed")
    if loop.axis_poles.size:
        listed = ", ".join(f"{w:.6g}" for w in np.unique(loop.axis_poles)[:6])
        notes.append(f"GH has poles on the imaginary axis at {listed} rad/s (|GH| is infinite there)")
    return notes


def _on_real_axis(grid: Detection) -> bool:
    finite = np.isfinite(grid.gh)
    return bool(np.all(np.abs(grid.gh.imag[finite]) <= NOISE * np.abs(grid.gh[finite])))
