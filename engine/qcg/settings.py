"""`qcg`'s settings: the listing's SIZE, EPS, LIMIT, STEP, the scaling rule, and the optimizer."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

from engine.errors import EngineError


@dataclass(frozen=True)
class QcgSettings:
    """CGFM (the report's method, the default): ``size``, ``eps``, ``limit`` (line searches),
    ``step``, ``max_expansions``, ``scaling``.  ``optimizer="lbfgsb"``: limited-memory BFGS
    with bounds on p = b/|b0| (docs/algorithms/qcg.md): ``limit`` iterations, ``gtol`` (the
    projected gradient's largest component, in p), ``ftol`` (the relative fall of F that ends
    the run), ``pairs`` (s, y pairs kept)."""

    size: float = 0.1
    eps: float = 1e-5
    limit: int = 50
    step: float = 2.0
    max_expansions: int = 15
    scaling: Literal["iteration", "initial", "none"] = "iteration"
    optimizer: Literal["cgfm", "lbfgsb"] = "cgfm"
    gtol: float = 1e-5
    ftol: float = 2.220446049250313e-09
    pairs: int = 10

    def __post_init__(self) -> None:
        if self.scaling not in ("iteration", "initial", "none"):
            raise EngineError(f"qcg: scaling must be 'iteration', 'initial' or 'none', not {self.scaling!r}")
        if self.optimizer not in ("cgfm", "lbfgsb"):
            raise EngineError(f"qcg: optimizer must be 'cgfm' or 'lbfgsb', not {self.optimizer!r}")
        if not (self.size > 0 and self.eps > 0 and self.step > 1 and self.limit >= 1):
            raise EngineError("qcg: need size > 0, eps > 0, step > 1, limit >= 1")
        if not (self.gtol >= 0 and self.ftol >= 0 and self.pairs >= 1):
            raise EngineError("qcg: need gtol >= 0, ftol >= 0, pairs >= 1")
