"""What a loop's shape means for its margins, said in notes: constant
levels, a Nyquist curve on the real axis, poles on the imaginary axis."""

from __future__ import annotations

import math

import numpy as np

from engine.loop.responses import LoopModel
from engine.margins.detection_grid import NOISE, Detection


def shape_notes(loop: LoopModel, grid: Detection) -> list[str]:
    """What the loop's shape means for its margins, as its detection grid shows it:
    constant levels, a Nyquist curve on the real axis, poles on the imaginary axis."""
    return level_notes(loop, grid.flat, complex(grid.gh[0]), _on_real_axis(grid))


def level_notes(loop: LoopModel, flat: frozenset[str], gh: complex, on_real_axis: bool = False) -> list[str]:
    """The notes of `shape_notes` from the constant levels (``flat``: "GH", "1+GH",
    "phase"), GH at any frequency, and whether GH is real at every frequency."""
    notes = []
    if "1+GH" in flat:
        notes.append(
            f"|1+GH| is constant ({abs(1 + gh):.6g}) at every frequency: no interior minimum (no stability margin)"
        )
    if "GH" in flat:
        level = abs(gh)
        notes.append(
            f"|GH| is constant ({level:.6g}) at every frequency"
            + (": its crossing of 1 is not isolated (no phase margin)" if abs(level - 1) < 1e-9 else "")
        )
    if "phase" in flat:
        notes.append(
            f"the phase of GH is constant ({math.degrees(np.angle(gh)) + 0.0:.6g} deg)"  # + 0.0: no "-0"
            + (
                ": on the negative real axis everywhere (gain crossings not isolated)"
                if abs(abs(np.angle(gh)) - math.pi) < 1e-9
                else ""
            )
        )
    elif on_real_axis:
        notes.append(
            "GH is real at every frequency (the Nyquist curve lies on the real axis): its crossings "
            "of the negative real axis are not isolated, so no gain margin is listed"
        )
    if loop.axis_poles.size:
        listed = ", ".join(f"{w:.6g}" for w in np.unique(loop.axis_poles)[:6])
        notes.append(f"GH has poles on the imaginary axis at {listed} rad/s (|GH| is infinite there)")
    return notes


def _on_real_axis(grid: Detection) -> bool:
    finite = np.isfinite(grid.gh)
    return bool(np.all(np.abs(grid.gh.imag[finite]) <= NOISE * np.abs(grid.gh[finite])))
