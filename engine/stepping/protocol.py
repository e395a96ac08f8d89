"""The stepper protocol every design algorithm follows.

An algorithm is bound to a problem and its settings (`Registration.bind`,
engine.stepping.registry), which gives a frozen `Stepper`; its `init()` returns
the first `State`, and `step(state)` the next state and a `StepRecord`, never
changing its input and depending on nothing but the problem, the settings and
the state (no clock: a wall-clock bound is the driver's, engine.stepping.driver's
``time_limit``).  States and records are frozen and convert to and from JSON
(`to_json`/`from_json`), so a session can store them and replay them; an
algorithm's memory is its own frozen class (`Memory`, the algorithm's
``memory_type``), whose ``from_json`` rejects malformed data.
"""

from __future__ import annotations

import dataclasses
import functools
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from enum import Enum
from typing import ClassVar, Protocol, Self, TypeVar

from engine.design.problem import Problem
from engine.errors import EngineError
from engine.stepping.memory_fields import Fields
from engine.stepping.memory_fields import jsonable as _jsonable

T = TypeVar("T")


class Settings(Protocol):
    """An algorithm's settings: a dataclass with a default for every field."""

    __dataclass_fields__: ClassVar[dict[str, dataclasses.Field[object]]]


class Status(str, Enum):
    """Every way an iteration can end."""

    RUNNING = "running"
    CONVERGED = "converged"
    NO_IMPROVEMENT = "no further improvement"
    STEP_BELOW_MINIMUM = "step below minimum"
    ITERATION_LIMIT = "iteration limit"
    INFEASIBLE = "infeasible"
    FAILED = "failed"

    @property
    def finished(self) -> bool:
        return self is not Status.RUNNING


@dataclass(frozen=True)
class MeasureRow:
    """One row of the tableau."""

    name: str
    kind: str
    condition: str
    value: float
    desired: float | None  # the target's desired value (None: a row shown without one)
    satisfied: bool
    frequency: float | None = None
    at_least: bool = True  # larger values are better (False: peaks, times, errors, attenuation)
    method: str | None = None  # margins: "refined", "fitted (residual ...)" or "grid"

    @staticmethod
    def from_json(data: object, where: str = "measure") -> MeasureRow:
        """A row from JSON (non-finite numbers as 'inf', '-inf', 'nan'); malformed data
        raises `EngineError` naming the field."""
        fields = Fields(data, where)
        _known_only(fields, {f.name for f in dataclasses.fields(MeasureRow)}, "a measure")
        return MeasureRow(
            fields.text("name"),
            fields.text("kind"),
            fields.text("condition"),
            fields.number("value", finite=False),
            fields.optional_number("desired", finite=False),
            fields.boolean("satisfied"),
            _or_default(fields, "frequency", None, functools.partial(fields.optional_number, finite=False)),
            _or_default(fields, "at_least", True, fields.boolean),
            _or_default(fields, "method", None, lambda name: None if fields.get(name) is None else fields.text(name)),
        )


def _known_only(fields: Fields, known: set[str], what: str) -> None:
    for name in fields.data:
        if name not in known:
            raise EngineError(f"{fields.where}.{name}: not a field of {what}")


def _or_default(fields: Fields, name: str, default: T, read: Callable[[str], T]) -> T:
    """``read(name)`` when the field is present, else ``default``."""
    return read(name) if name in fields.data else default


def _status(fields: Fields) -> Status:
    status = fields.text("status")
    if status not in {s.value for s in Status}:
        raise EngineError(
            f"{fields.where}.status: expected one of {', '.join(s.value for s in Status)}, got {status!r}"
        )
    return Status(status)


def _parameters(fields: Fields) -> dict[str, float | list[float]]:
    """name -> a finite number, or a list of them (one per condition)."""
    return {
        name: list(fields.numbers(name)) if isinstance(value, list) else fields.number(name)
        for name, value in fields.data.items()
    }


def _counters(fields: Fields) -> dict[str, int]:
    return {name: fields.integer(name, minimum=None) for name in fields.data}


@dataclass(frozen=True)
class StepRecord:
    """What one iteration did: the tableau, the step, the counters."""

    iteration: int
    status: Status
    parameters: Mapping[str, float | list[float]]
    measures: tuple[MeasureRow, ...]
    objective: float | None = None
    step_size: float | None = None
    direction: tuple[float, ...] = ()
    counters: Mapping[str, int] = field(default_factory=dict)
    reason: str = ""
    extra: Mapping[str, object] = field(default_factory=dict)

    def to_json(self) -> dict:
        data = {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}
        data["measures"] = [dataclasses.asdict(m) for m in self.measures]
        return _jsonable(data)

    @staticmethod
    def from_json(data: object, where: str = "record") -> StepRecord:
        """A record from JSON; malformed data raises `EngineError` naming the field
        (``where`` names the record).  Keys other than a record's fields are the caller's;
        ``extra`` stays free-form (presenters read it with ``.get``)."""
        fields = Fields(data, where)
        opt = functools.partial(_or_default, fields)
        unbounded = functools.partial(fields.optional_number, finite=False)
        return StepRecord(
            iteration=fields.integer("iteration"),
            status=_status(fields),
            parameters=_parameters(fields.object("parameters")),
            measures=tuple(MeasureRow.from_json(m.data, m.where) for m in fields.objects("measures")),
            objective=opt("objective", None, unbounded),
            step_size=opt("step_size", None, unbounded),
            direction=opt("direction", (), functools.partial(fields.numbers, finite=False)),
            counters=_counters(fields.object("counters")) if "counters" in fields.data else {},
            reason=opt("reason", "", fields.text),
            extra=dict(fields.object("extra").data) if "extra" in fields.data else {},
        )


class Memory(Protocol):
    """An algorithm's memory between iterations: a frozen dataclass (tuples, never
    lists, inside) that converts to JSON and back; ``from_json`` raises `EngineError`
    naming the field when the data is malformed."""

    def to_json(self) -> dict: ...

    @classmethod
    def from_json(cls, data: object) -> Self: ...


@dataclass(frozen=True)
class State:
    """An algorithm's state between iterations: the free vector, its status,
    and the algorithm's memory (its ``memory_type``)."""

    iteration: int
    x: tuple[float, ...]
    status: Status
    memory: Memory

    def to_json(self) -> dict:
        memory = self.memory.to_json()  # a memory that writes plain JSON is not walked again
        return {
            **_jsonable({"iteration": self.iteration, "x": self.x, "status": self.status}),
            "memory": memory if getattr(type(self.memory), "PLAIN_JSON", False) else _jsonable(memory),
        }

    @staticmethod
    def from_json(data: object, memory_type: type[Memory]) -> State:
        """A state from JSON; malformed data (memory included) raises `EngineError`."""
        fields = Fields(data, "state")
        status = _status(fields)
        return State(
            fields.integer("iteration"), fields.numbers("x"), status, memory_type.from_json(fields.get("memory"))
        )


class Stepper(Protocol):
    """The stepper protocol (docs/architecture.md): an algorithm bound to one problem and
    its settings (`Registration.bind`), frozen from then on.  `init` gives the first
    state; `step` the next state and its record, a function of the state alone.
    ``memory_type`` reads a stored state's memory back (`State.from_json`)."""

    memory_type: ClassVar[type[Memory]]

    @property
    def problem(self) -> Problem: ...

    @property
    def settings(self) -> Settings: ...

    def init(self) -> State: ...

    def step(self, state: State) -> tuple[State, StepRecord]: ...


class BoundStepper:
    """The base of the bundled steppers: `bind` makes one for a problem and settings,
    `setup` (the subclass's) computes what the algorithm keeps of them, and from then on
    the stepper is frozen: an assignment to it raises, so nothing a step does can leak
    into the next one."""

    name: ClassVar[str]
    memory_type: ClassVar[type[Memory]]
    problem: Problem
    settings: Settings

    @classmethod
    def bind(cls, problem: Problem, settings: Settings) -> Self:
        stepper = cls.__new__(cls)
        object.__setattr__(stepper, "problem", problem)
        object.__setattr__(stepper, "settings", settings)
        stepper.setup()
        object.__setattr__(stepper, "bound", True)
        return stepper

    def setup(self) -> None:
        """What the algorithm keeps of its problem and settings (checks included)."""

    def __setattr__(self, name: str, value: object) -> None:
        if getattr(self, "bound", False):
            raise AttributeError(f"{self.name}: a bound stepper does not change ({name})")
        object.__setattr__(self, name, value)
