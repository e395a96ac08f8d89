"""What `qcg` keeps between line searches (`QcgMemory`), and its JSON."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Self

from ..errors import EngineError
from ..memory import Fields, jsonable


@dataclass(frozen=True)
class QcgMemory:
    """The listing's SIZE, NCYC (iterations since the last restart), TSAVE (|g|^2 of the
    last direction), the last direction h, KNT (cost evaluations), KOUNT (line searches),
    and |b| at the start (the `initial` scaling)."""

    size: float
    ncyc: int
    tsave: float
    direction: tuple[float, ...]
    knt: int
    kount: int
    initial_scale: tuple[float, ...]

    def to_json(self) -> dict:
        """Plain JSON types."""
        return jsonable({"size": self.size, "ncyc": self.ncyc, "tsave": self.tsave, "direction": self.direction,
                         "knt": self.knt, "kount": self.kount, "initial_scale": self.initial_scale})

    @classmethod
    def from_json(cls, data: Any) -> Self:
        """Read back `to_json`'s data; malformed data raises `EngineError` naming the field."""
        fields = Fields(data, "qcg memory")
        size = fields.number("size")
        if not size > 0:
            raise EngineError(f"qcg memory.size: expected a number > 0, got {size!r}")
        direction = fields.numbers("direction")
        return cls(size, fields.integer("ncyc"), fields.number("tsave"), direction, fields.integer("knt"),
                   fields.integer("kount"), fields.numbers("initial_scale", len(direction)))
