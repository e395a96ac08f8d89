"""What `qcg` keeps between steps (`QcgMemory`), and its JSON."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Self

from engine.errors import EngineError
from engine.qcg.evaluate import Evaluation
from engine.stepping.memory_fields import Fields, jsonable


@dataclass(frozen=True)
class QcgMemory:
    """Both optimizers' memory.

    CGFM: the listing's SIZE, NCYC (iterations since the last restart), TSAVE (|g|^2 of
    the last direction), the last direction h.  L-BFGS-B: the last pairs s, y of the
    scaled parameters p = b/|b0| and their gradients (oldest first).  Both: KNT (the
    search's cost evaluations), KOUNT (line searches, iterations), ``evaluations`` (every
    cost evaluation, the open-loop reference included) and ``gradients`` (those that
    included the gradient), |b| at the start (``initial_scale``: CGFM's `initial`
    scaling, L-BFGS-B's b0), and the cost at the current point (``last``: the next
    step starts from it, a record is made from it)."""

    size: float
    ncyc: int
    tsave: float
    direction: tuple[float, ...]
    knt: int
    kount: int
    initial_scale: tuple[float, ...]
    evaluations: int
    gradients: int
    last: Evaluation | None = None
    pairs_s: tuple[tuple[float, ...], ...] = ()
    pairs_y: tuple[tuple[float, ...], ...] = ()

    def to_json(self) -> dict:
        """Plain JSON types."""
        return jsonable(
            {
                "size": self.size,
                "ncyc": self.ncyc,
                "tsave": self.tsave,
                "direction": self.direction,
                "knt": self.knt,
                "kount": self.kount,
                "initial_scale": self.initial_scale,
                "evaluations": self.evaluations,
                "gradients": self.gradients,
                "last": None if self.last is None else self.last.to_json(),
                "pairs_s": self.pairs_s,
                "pairs_y": self.pairs_y,
            }
        )

    @classmethod
    def from_json(cls, data: Any) -> Self:
        """Read back `to_json`'s data; malformed data raises `EngineError` naming the field."""
        fields = Fields(data, "qcg memory")
        size = fields.number("size")
        if not size > 0:
            raise EngineError(f"qcg memory.size: expected a number > 0, got {size!r}")
        direction = fields.numbers("direction")
        n = len(direction)
        last = None if fields.get("last") is None else Evaluation.from_json(fields.object("last"), n)
        pairs_s = fields.matrix("pairs_s", columns=n)
        return cls(
            size,
            fields.integer("ncyc"),
            fields.number("tsave"),
            direction,
            fields.integer("knt"),
            fields.integer("kount"),
            fields.numbers("initial_scale", n),
            fields.integer("evaluations"),
            fields.integer("gradients"),
            last,
            pairs_s,
            fields.matrix("pairs_y", len(pairs_s), n),
        )
