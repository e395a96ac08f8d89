"""The design problem every algorithm reads: flight conditions, tunable
parameters, targets, an objective, and the frequency grid.

Parameters are shared by all conditions or have one value per condition.
The algorithms move the *free* ones, as a flat vector of free values
(per-condition parameters contribute one entry per condition); `Problem`'s
docstring lists the few methods that translate between it and named values.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from functools import cached_property
from typing import Any, Literal

import numpy as np
from numpy.typing import NDArray

from engine.design.constraints import LinearInequality, check_inequalities, inequality_rows
from engine.design.measure_kinds import MEASURE_KINDS
from engine.design.measure_kinds import names as measure_names
from engine.errors import EngineError
from engine.model.blocks import FrequencyTable
from engine.model.network import Network, check_grid

Sign = Literal["any", "positive", "negative"]
# read from the table of measure kinds (`engine.design.measure_kinds`), kept here for their importers
FREQUENCY_MEASURES = measure_names("frequency")
TIME_MEASURES = measure_names("time")
MEASURE_NAMES = measure_names()
# measures whose natural sense is "at most" (smaller is better); the rest are "at least"
AT_MOST = tuple(name for name, k in MEASURE_KINDS.items() if not k.at_least)
Value = float | tuple[float, ...]


@dataclass(frozen=True)
class Parameter:
    """A tunable parameter; ``value`` is a float, or a tuple (one per condition)."""

    name: str
    value: Value
    minimum: float = -np.inf
    maximum: float = np.inf
    free: bool = True
    sign: Sign = "any"

    @property
    def per_condition(self) -> bool:
        return isinstance(self.value, tuple)

    def at(self, condition: int) -> float:
        return self.value[condition] if isinstance(self.value, tuple) else self.value

    def lower(self) -> float:
        """Lower bound, including the sign constraint."""
        return max(self.minimum, 0.0) if self.sign == "positive" else self.minimum

    def upper(self) -> float:
        return min(self.maximum, 0.0) if self.sign == "negative" else self.maximum


@dataclass(frozen=True)
class Condition:
    """One flight condition: a plant interconnection and where its loop is broken."""

    name: str
    network: Network
    break_at: str
    breaks: tuple[str, ...] = ()  # every loop break analyze reports (empty: break_at alone)

    @property
    def every_break(self) -> tuple[str, ...]:
        """Every loop break of the condition (its ``breaks``, else its ``break_at`` alone)."""
        return self.breaks or (self.break_at,)

    @property
    def several_breaks(self) -> bool:
        """Whether the condition names other loop breaks than its primary one."""
        return self.every_break != (self.break_at,)


@dataclass(frozen=True)
class BandValue:
    """A desired value that holds for frequencies in [low, high] (rad/s).

    ``required``: the least acceptable value (the most, for an at-most
    measure), where it differs from ``desired``; slp constrains it and
    rewards improvement only up to ``desired``.  None: the desired value
    is the requirement.
    """

    low: float
    high: float
    desired: float
    required: float | None = None

    @property
    def requirement(self) -> float:
        return self.desired if self.required is None else self.required


@dataclass(frozen=True)
class Point:
    """A push or pull point in the GH plane."""

    value: complex
    mode: Literal["push", "pull"]


@dataclass(frozen=True)
class TimeResponse:
    """The response a time-domain measure reads: ``output`` for an input profile
    (steps and ramps, as `engine.closed_loop.time_response.Segment`) applied at ``input``, over
    [0, horizon] at ``points`` samples.  ``psd``: for a mean square, a shaping
    filter F(s) whose |F(jw)|^2 is the input's power spectral density.
    ``reference``: the value the output should settle at (steady-state error)."""

    input: str
    output: str
    horizon: float = 10.0
    points: int = 400
    profile: tuple[tuple[float, float, float], ...] = ((0.0, 1.0, 0.0),)  # (time, step, slope)
    psd: str | None = None
    reference: float = 1.0
    settling_band: float = 0.05


@dataclass(frozen=True)
class LinearEquality:
    """sum coefficient * parameter = value; a term names a parameter and, for one
    with a value per condition, the condition index (None: shared)."""

    terms: tuple[tuple[str, int | None, float], ...]
    value: float


@dataclass(frozen=True)
class Target:
    """A requirement on one measure kind, in one condition or all of them."""

    measure: str
    bands: tuple[BandValue, ...]
    condition: str | None = None
    weight: float = 1.0
    scale: float = 1.0
    points: tuple[Point, ...] = ()
    detect_low: float = 0.0
    detect_high: float = np.inf
    sense: Literal["at_least", "at_most"] | None = None  # None: the measure's natural sense
    requirement: bool = True  # False: only in the objective (e.g. a peak load to minimize), never judged met
    response: TimeResponse | None = None  # for time-domain measures
    loop_break: str | None = None  # the break the measure is read at (None: the condition's break_at)

    def break_in(self, condition: Condition) -> str:
        """The signal where this target's measure is read in ``condition``."""
        return condition.break_at if self.loop_break is None else self.loop_break

    @property
    def at_least(self) -> bool:
        """True when larger values are better."""
        if self.sense is not None:
            return self.sense == "at_least"
        return self.measure not in AT_MOST

    def desired(self, frequency: float) -> float | None:
        """The desired value at a frequency (the first band containing it), or None."""
        for band in self.bands:
            if band.low <= frequency <= band.high:
                return band.desired
        return None


@dataclass(frozen=True)
class Grid:
    """Frequencies in rad/s, with the unit the user chose for display."""

    omega: NDArray[np.float64]
    unit: Literal["rad/s", "hz"] = "rad/s"


@dataclass(frozen=True)
class Objective:
    """What an algorithm minimizes or maximizes, where it has one (kind + options)."""

    kind: str
    options: Mapping[str, float | str] = field(default_factory=dict)
    tables: Mapping[str, FrequencyTable] = field(default_factory=dict)  # e.g. a noise PSD
    data: Mapping[str, Any] = field(default_factory=dict)  # structured inputs (e.g. a DAE's matrices)


@dataclass(frozen=True)
class Problem:
    """Conditions, parameters, targets, grid, objective and linear equalities.

    Parameter values, at the start (the parameters' own values) or at a free vector ``x``:

    - ``vector()``: the free vector at the start (per-condition parameters contribute
      one entry per condition, in `free_slots` order);
    - ``with_vector(x)``: a copy of the problem with the free values replaced by ``x``;
    - ``condition_values(c, x=None, named=None)``: name -> float, what condition ``c``
      sees at the start, with ``x`` (no copy), or with a ``named`` mapping replacing
      the values it names;
    - ``named(x=None)``: name -> float, or list per condition (JSON-ready);
    - ``vector_from(named)``: the inverse of ``named``: the free vector of a mapping
      (names it leaves out keep their start values).
    """

    conditions: tuple[Condition, ...]
    parameters: tuple[Parameter, ...]
    targets: tuple[Target, ...]
    grid: Grid
    objective: Objective | None = None
    equalities: tuple[LinearEquality, ...] = ()
    inequalities: tuple[LinearInequality, ...] = ()  # A x <= b: `linear_constraints`
    noise_factor: float = 100.0  # a compensator's |K(j inf)| / |K(j wc)| above which a design is flagged

    def __post_init__(self) -> None:
        if not self.conditions and (self.objective is None or self.objective.kind != "dae"):
            raise EngineError("a problem needs at least one condition (only a 'dae' objective stands alone)")
        check_grid(self.grid.omega, "problem grid")
        names = [p.name for p in self.parameters]
        if len(set(names)) != len(names):
            raise EngineError("parameter names must be unique")
        for p in self.parameters:
            if p.per_condition and len(p.value) != len(self.conditions):
                raise EngineError(
                    f"parameter {p.name!r} has {len(p.value)} values for {len(self.conditions)} conditions"
                )
        needed = {q for c in self.conditions for q in c.network.parameters}
        unknown = [t.measure for t in self.targets if t.measure not in MEASURE_NAMES]
        if unknown:
            raise EngineError(f"unknown measure {unknown[0]!r}; known: {', '.join(MEASURE_NAMES)}")
        missing = sorted(needed - set(names))
        if missing:
            raise EngineError(f"no parameter defined for {', '.join(missing)}")
        for t in self.targets:
            if t.measure in TIME_MEASURES and t.response is None:
                raise EngineError(f"measure {t.measure!r} needs a response (input, output, horizon)")
        for k, eq in enumerate(self.equalities):
            self._check_equality(eq, f"equalities[{k}]")
        check_inequalities(self)

    def _check_equality(self, eq: LinearEquality, where: str) -> None:
        by_name = {p.name: p for p in self.parameters}
        for name, c, _ in eq.terms:
            p = by_name.get(name)
            if p is None:
                raise EngineError(f"{where}: unknown parameter {name!r}")
            if p.per_condition != (c is not None) or (c is not None and not 0 <= c < len(self.conditions)):
                raise EngineError(
                    f"{where}: {name!r} "
                    + (
                        "has one value per condition: name the condition"
                        if p.per_condition
                        else "is shared by all conditions"
                    )
                )

    @cached_property
    def linear_constraints(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """(A, b) with A x <= b over the free vector: the rows of `inequalities` that hold a free
        parameter (fixed ones moved to b; `engine.design.constraints`).  Read-only arrays."""
        rows = inequality_rows(self)
        A, b = rows.A[rows.free], rows.b[rows.free]
        A.flags.writeable = b.flags.writeable = False
        return A, b

    def equality_system(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """(A, b) with A x = b over the free vector (fixed parameters moved to b)."""
        slots = {(self.parameters[i].name, c): k for k, (i, c) in enumerate(self.free_slots())}
        values = {p.name: p for p in self.parameters}
        A = np.zeros((len(self.equalities), len(slots)))
        b = np.zeros(len(self.equalities))
        for r, eq in enumerate(self.equalities):
            b[r] = eq.value
            for name, c, coefficient in eq.terms:
                k = slots.get((name, c))
                if k is None:
                    b[r] -= coefficient * values[name].at(0 if c is None else c)
                else:
                    A[r, k] += coefficient
        return A, b

    def free_slots(self) -> list[tuple[int, int | None]]:
        """(parameter index, condition or None) for every entry of the free vector."""
        return list(self._free_slots)

    @cached_property
    def _free_slots(self) -> tuple[tuple[int, int | None], ...]:
        slots: list[tuple[int, int | None]] = []
        for i, p in enumerate(self.parameters):
            if p.free:
                slots += [(i, c) for c in range(len(self.conditions))] if p.per_condition else [(i, None)]
        return tuple(slots)

    @cached_property
    def slot_index(self) -> dict[tuple[str, int], int]:
        """(parameter name, condition) -> position in the free vector."""
        index = {}
        for k, (i, c) in enumerate(self._free_slots):
            for condition in range(len(self.conditions)) if c is None else (c,):
                index[(self.parameters[i].name, condition)] = k
        return index

    def vector(self) -> NDArray[np.float64]:
        return np.array(
            [self.parameters[i].value[c] if c is not None else self.parameters[i].value for i, c in self.free_slots()],
            dtype=float,
        )

    def bounds(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        slots = self.free_slots()
        return (
            np.array([self.parameters[i].lower() for i, _ in slots]),
            np.array([self.parameters[i].upper() for i, _ in slots]),
        )

    def with_vector(self, x: Sequence[float]) -> Problem:
        """A copy with the free values replaced by ``x``."""
        values: dict[int, Value] = {i: p.value for i, p in enumerate(self.parameters)}
        for (i, c), v in zip(self.free_slots(), x, strict=True):
            if c is None:
                values[i] = float(v)
            else:
                per = list(values[i])
                per[c] = float(v)
                values[i] = tuple(per)
        return replace(self, parameters=tuple(replace(p, value=values[i]) for i, p in enumerate(self.parameters)))

    def condition_values(
        self,
        condition: int,
        x: Sequence[float] | None = None,
        named: Mapping[str, float | Sequence[float]] | None = None,
    ) -> dict[str, float]:
        """Parameter values one condition sees: at the start, with the free vector ``x``, or with
        ``named`` (as `named` gives it) replacing the values it names; ``x`` does not copy the problem."""
        if x is not None and named is not None:
            raise EngineError("condition_values takes a free vector or a named mapping, not both")
        base, slots = self._slot_names
        values = dict(base[condition]) if condition < len(base) else self._start_values(condition)
        if x is not None:
            for (name, c), v in zip(slots, x, strict=True):
                if c is None or c == condition:
                    values[name] = float(v)
        for name, value in (named or {}).items():
            values[name] = float(value[condition] if isinstance(value, (list, tuple)) else value)
        return values

    def _start_values(self, condition: int) -> dict[str, float]:
        return {p.name: p.at(condition) for p in self.parameters}

    @cached_property
    def _slot_names(self) -> tuple[tuple[dict[str, float], ...], tuple[tuple[str, int | None], ...]]:
        """The parameter values per condition, and (name, condition) of each free slot."""
        base = tuple(self._start_values(c) for c in range(max(len(self.conditions), 1)))
        return base, tuple((self.parameters[i].name, c) for i, c in self._free_slots)

    def named(self, x: Sequence[float] | None = None) -> dict[str, float | list[float]]:
        """name -> value, or name -> list per condition (JSON-ready), at the start or with ``x``."""
        named = {p.name: list(p.value) if p.per_condition else p.value for p in self.parameters}
        if x is not None:
            for (i, c), v in zip(self.free_slots(), x, strict=True):
                name = self.parameters[i].name
                if c is None:
                    named[name] = float(v)
                else:
                    named[name][c] = float(v)
        return named

    def vector_from(self, named: Mapping[str, float | Sequence[float]]) -> NDArray[np.float64]:
        """The free vector of a named mapping (as `named` gives it); missing names keep the start values."""
        by_name = {p.name: p for p in self.parameters}
        unknown = sorted(set(named) - set(by_name))
        if unknown:
            raise EngineError(f"unknown parameter {unknown[0]!r}")
        for name, value in named.items():
            if isinstance(value, (list, tuple)) and (
                not by_name[name].per_condition or len(value) != len(self.conditions)
            ):
                raise EngineError(
                    f"parameter {name!r}: expected "
                    + (f"{len(self.conditions)} values" if by_name[name].per_condition else "one value")
                )
        x = self.vector()
        for k, (i, c) in enumerate(self._free_slots):
            value = named.get(self.parameters[i].name)
            if value is not None:
                x[k] = float(value[c] if isinstance(value, (list, tuple)) else value)
        return x
