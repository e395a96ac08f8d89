"""cip's requirements for the closed-loop peaks (`engine.margins.peak_measures`).

Each peak measure is a stability margin: with f its transform of GH (S,
T or S - 1/2) and 1 + F = 1/f,
  Ms <= M      is   |1 + GH| >= 1/M at every frequency: cip's stability
               margin itself (family S: the local minima of |1 + GH| from
               `engine.margins.search`, pushed from -1; `requirements._requirement`
               converts the desired value and shows 1/|1 + GH|);
  Mt <= M      is   |1 + 1/GH| = 1/|T| >= 1/M;
  alpha >= a   is   |1 + F| = 2|1 + GH|/|1 - GH| = 1/|S - 1/2| >= a (skew 0).
For Mt and the disk margin (family D) the requirements are the local maxima
of |f| in the target's detection band (refined, or the grid's on a
tabulated loop), valued 1/|T| or alpha there, each pushed from its Newton
point q = GH + f/(df/dGH): cip's row 2 Re(conj(GH - q) dGH/dx) is then a
positive multiple of d|1 + F|^2/dx, so after cip scales rows to unit length
the direction is exactly the one a stability margin of F would get.
"""

from __future__ import annotations

from engine.cip.requirements import KIND, Requirement
from engine.design.problem import Point, Target
from engine.errors import EngineError
from engine.loop.responses import LoopModel
from engine.margins.peak_measures import local_peaks, newton_point
from engine.margins.search import Band

INVERTED = ("sensitivity_peak", "complementary_sensitivity_peak")  # at most M: the distance is 1/value


def check_peak_targets(targets: tuple[Target, ...]) -> None:
    """Peak targets cip can improve: no points for D targets (each row has its own)."""
    for k, target in enumerate(targets):
        if KIND.get(target.measure) == "D" and target.points:
            raise EngineError(
                f"cip: target {k} ({target.measure}) takes no points: cip pushes it along its "
                "own gradient (docs/algorithms/cip.md)"
            )


def peak_requirements(loop: LoopModel, targets: list[tuple[int, Target]], c: int) -> list[Requirement]:
    """The family-D requirements (Mt, disk margin) of one condition's targets."""
    out = []
    method = "refined" if loop.evaluate is not None else "grid"
    for i, target in targets:
        if KIND[target.measure] != "D":
            continue
        for w, magnitude, gh in local_peaks(loop, target.measure, Band(target.detect_low, target.detect_high)):
            desired = target.desired(w)
            if desired is None or not magnitude > 0:
                continue
            value = 1.0 / magnitude  # 1/|T| or alpha: |1 + F|
            shown = magnitude if target.measure in INVERTED else value
            goal = inverse(desired) if target.measure in INVERTED else desired
            out.append(
                Requirement(
                    f"{target.measure}#{i}@{c}",
                    "D",
                    target.measure,
                    c,
                    w,
                    value,
                    goal,
                    shown,
                    desired,
                    target.weight,
                    (Point(newton_point(target.measure, gh), "push"),),
                    gh,
                    method,
                )
            )
    return out


def inverse(desired: float) -> float:
    """The distance goal 1/M of an at-most peak M (inf for M <= 0: never met, as Ms <= 0 cannot be)."""
    return 1.0 / desired if desired > 0 else float("inf")
