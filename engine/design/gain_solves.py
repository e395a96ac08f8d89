"""The loop-gain solves a designer reaches for, exact on the loop (not read off a grid):
the gain factor that puts the gain crossover at a given frequency, and the one that
gives a phase margin.  A tabulated loop is solved on its rational fit (the margins'
`fitted_loop`), and says so.

The phase of K*GH does not depend on K > 0, so a phase margin PM at a crossover w needs
angle GH(jw) = -180 + PM (mod 360) there: every such w is found (sign changes of
Im(GH e^(-j theta)) on a dense log grid, refined by Brent's method on the exact loop),
each gives K = 1/|GH(jw)|, and a candidate stands only when, at that gain, no other
crossover has a smaller phase margin."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import brentq

from engine.errors import EngineError
from engine.loop.responses import LoopModel, SampledLoop
from engine.margins.search import fitted_loop

POINTS_PER_DECADE = 200
REACH = 2.0  # decades searched beyond the loop's grid on each side
XTOL = 1e-15  # Brent's relative tolerance on the frequency (near its least, 4 eps)
GRID_MARGIN = 0.5  # deg: another crossover's margin, read on the search grid, may be this far below


@dataclass(frozen=True)
class GainSolution:
    """Multiply the loop by ``factor``: its gain crossover is then at ``frequency``
    (rad/s) with ``phase_margin`` (deg); ``note``: how it was solved."""

    factor: float
    frequency: float
    phase_margin: float
    note: str


def gain_for(loop: LoopModel, goal: str, target: float) -> GainSolution:
    """The gain for ``goal``: "crossover" (``target`` in rad/s) or "pm" (in deg)."""
    if goal not in ("crossover", "pm"):
        raise EngineError(f"a gain is solved for a crossover or a phase margin (pm), not {goal!r}")
    return gain_for_crossover(loop, target) if goal == "crossover" else gain_for_phase_margin(loop, target)


def gain_for_crossover(loop: LoopModel, frequency: float) -> GainSolution:
    """The factor that makes |K GH(j frequency)| = 1."""
    exact, note, _ = _exact(loop)
    if not (frequency > 0 and math.isfinite(frequency)):
        raise EngineError(f"a crossover frequency must be positive and finite, not {frequency!r}")
    gh = complex(exact.evaluate(np.array([frequency]))[0][0])
    if not (abs(gh) > 0 and math.isfinite(abs(gh))):
        raise EngineError(f"|GH| at {frequency:g} rad/s is {abs(gh):g}: no finite gain puts the crossover there")
    return GainSolution(1.0 / abs(gh), frequency, _margin(gh), note)


def gain_for_phase_margin(loop: LoopModel, phase_margin: float) -> GainSolution:
    """The factor that gives the loop a phase margin of ``phase_margin`` deg at its
    critical crossover, the lowest such crossover frequency when several gains do
    (`phase_margin_solutions` lists them all); an `EngineError` says why none does."""
    return phase_margin_solutions(loop, phase_margin)[0]


def phase_margin_solutions(loop: LoopModel, phase_margin: float) -> list[GainSolution]:
    """Every factor that gives the loop a phase margin of ``phase_margin`` deg at its
    critical crossover, ordered by that crossover's frequency; an `EngineError` says
    why none does."""
    exact, note, reach = _exact(loop)
    if not -180.0 < phase_margin < 180.0:
        raise EngineError(f"a phase margin lies in (-180, 180) deg, not {phase_margin!r}")
    w = _search_grid(exact, reach)
    gh = exact.evaluate(w)[0]
    theta = math.radians(phase_margin - 180.0)
    rotated = gh * np.exp(-1j * theta)  # real and positive where angle GH = -180 + PM
    found = []
    for lo, hi in _brackets(rotated):
        root = brentq(lambda x: (_gh(exact, x) * np.exp(-1j * theta)).imag, w[lo], w[hi], xtol=1e-300, rtol=XTOL)
        value = _gh(exact, root)
        if (value * np.exp(-1j * theta)).real > 0 and abs(value) > 0:
            found.append((root, value))
    if not found:
        raise EngineError(
            f"the loop's phase never reaches {phase_margin - 180:g} deg (mod 360) between "
            f"{w[0]:.3g} and {w[-1]:.3g} rad/s: no gain gives a {phase_margin:g} deg phase margin"
        )
    standing = []
    for root, value in found:
        factor = 1.0 / abs(value)
        worst = _worst_margin(w, factor * gh)
        if worst is None or worst >= phase_margin - GRID_MARGIN:
            standing.append(GainSolution(factor, root, _margin(value), note))
    if not standing:
        raise EngineError(
            f"at each gain that gives {phase_margin:g} deg at one crossover "
            f"({', '.join(f'{r:.4g}' for r, _ in found)} rad/s), another crossover has a smaller phase margin"
        )
    return standing


def _exact(loop: LoopModel) -> tuple[LoopModel, str, float]:
    """The loop to solve on, how, and how many decades beyond its grid to search (a
    table's fit holds within the table's range only)."""
    if loop.evaluate is not None:
        return loop, "exact on the loop", REACH
    fitted = fitted_loop(loop)
    if fitted is None:
        raise EngineError("the table fits no rational model well enough to solve on it")
    return fitted.model, f"on {fitted.how} (residual {fitted.residual:.2g})", 0.0


def _search_grid(loop: LoopModel, reach: float) -> NDArray[np.float64]:
    """``reach`` decades beyond the loop's grid each side (a sampled loop's: up to just below pi/T)."""
    omega = loop.omega[loop.omega > 0]
    low, high = math.log10(omega.min()) - reach, math.log10(omega.max()) + reach
    if isinstance(loop, SampledLoop):
        high = min(high, math.log10(math.pi / loop.sample_time * (1 - 1e-9)))
    return np.logspace(low, high, int((high - low) * POINTS_PER_DECADE) + 1)


def _brackets(rotated: NDArray[np.complex128]) -> list[tuple[int, int]]:
    """Grid intervals where Im changes sign with Re > 0 at an end (not the -PM branch)."""
    im, re = rotated.imag, rotated.real
    change = np.flatnonzero((np.sign(im[:-1]) != np.sign(im[1:])) & np.isfinite(im[:-1]) & np.isfinite(im[1:]))
    return [(i, i + 1) for i in change if re[i] > 0 or re[i + 1] > 0]


def _gh(loop: LoopModel, w: float) -> complex:
    return complex(loop.evaluate(np.array([w]))[0][0])


def _margin(gh: complex) -> float:
    """The phase margin (deg) of a crossover where the loop is ``gh``: 180 + angle, in (-180, 180]."""
    return (math.degrees(np.angle(gh)) + 360.0) % 360.0 - 180.0


def _worst_margin(w: NDArray, gh: NDArray) -> float | None:
    """The smallest phase margin over the crossovers of |gh| = 1 on the grid (None: none)."""
    level = np.abs(gh) - 1.0
    crossings = np.flatnonzero(np.sign(level[:-1]) != np.sign(level[1:]))
    if not crossings.size:
        return None
    return min(_margin(gh[i] if abs(level[i]) < abs(level[i + 1]) else gh[i + 1]) for i in crossings)
