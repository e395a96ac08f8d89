"""The stepper protocol every design algorithm follows, and its registry.

An algorithm is set up with `init(problem, settings)`, which returns the first
`State`; `step(state)` returns the next state and a `StepRecord`, never
changes its input, and depends on nothing but the problem, the settings and
the state (no clock: a wall-clock bound is the driver's, `iterate`'s
``time_limit``).  States and records are frozen and convert to and from JSON
(`to_json`/`from_json`), so a session can store them and replay them; an
algorithm's memory is its own frozen class (`Memory`, the algorithm's
``memory_type``), whose ``from_json`` rejects malformed data.
"""

from __future__ import annotations

import dataclasses
import functools
import importlib
import time
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass, field
from enum import Enum
from typing import TYPE_CHECKING, ClassVar, Protocol, Self, TypeVar

from engine.design.problem import Problem
from engine.errors import EngineError
from engine.stepping.memory_fields import Fields
from engine.stepping.memory_fields import jsonable as _jsonable

if TYPE_CHECKING:
    from engine.stepping.presenter import Presenter

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


class Algorithm(Protocol):
    """The stepper protocol (docs/architecture.md): `init` binds the problem and settings;
    ``memory_type`` reads a stored state's memory back (`State.from_json`)."""

    name: str
    memory_type: ClassVar[type[Memory]]

    def init(self, problem: Problem, settings: Settings) -> State: ...

    def step(self, state: State) -> tuple[State, StepRecord]: ...


@dataclass(frozen=True)
class Registration:
    """An algorithm's factory, its settings class (a dataclass with defaults), a
    summary, and its presenter (`engine.stepping.presenter.Presenter`: how its records are shown)."""

    factory: Callable[[], Algorithm]
    settings: type[Settings]
    summary: str
    presenter: Presenter


REGISTRY: dict[str, Registration] = {}
# the report algorithms: name -> the package that registers it when imported (one at a time, on demand)
BUILTIN = {"cip": "engine.cip", "qcg": "engine.qcg", "slp": "engine.slp", "projection": "engine.projection"}


def load_builtin() -> dict[str, Registration]:
    """Import every bundled algorithm (they register themselves); the registry."""
    for module in BUILTIN.values():
        importlib.import_module(module)
    return REGISTRY


def register(
    name: str,
    factory: Callable[[], Algorithm],
    settings: type[Settings],
    summary: str,
    presenter: Presenter | None = None,
) -> None:
    """Make an algorithm known to the CLI, the app and sweeps by name (without a
    presenter, its records are shown the generic way)."""
    if presenter is None:
        from engine.stepping.presenter import Presenter

        presenter = Presenter()
    REGISTRY[name] = Registration(factory, settings, summary, presenter)


def lookup(name: str) -> Registration:
    """The registration of an algorithm (a bundled one is imported on first use)."""
    if name not in REGISTRY and name in BUILTIN:
        importlib.import_module(BUILTIN[name])
    if name not in REGISTRY:
        known = ", ".join(sorted(set(REGISTRY) | set(BUILTIN)))
        raise EngineError(f"unknown algorithm {name!r} (known: {known})")
    return REGISTRY[name]


def memory_type(name: str) -> type[Memory]:
    """The memory class of a registered algorithm (what `State.from_json` reads its memory with)."""
    factory = lookup(name).factory
    return getattr(factory, "memory_type", None) or factory().memory_type


def make_settings(name: str, values: Mapping[str, object]) -> Settings:
    """The algorithm's settings from a mapping; unknown names are an error."""
    cls = lookup(name).settings
    names = {f.name for f in dataclasses.fields(cls)}
    unknown = sorted(set(values) - names)
    retired = getattr(cls, "RETIRED", {})
    for setting in unknown:
        if setting in retired:
            raise EngineError(f"{name}: {setting!r} is no longer a setting: {retired[setting]}")
    if unknown:
        raise EngineError(f"{name}: unknown setting(s) {', '.join(unknown)}; settings are {', '.join(sorted(names))}")
    from engine.stepping.guard import setting_value, settings_types  # the settings' declared types, checked here once

    kinds = settings_types(cls)
    values = {
        key: setting_value(name, key, kinds[key], value) if key in kinds else value for key, value in values.items()
    }
    try:
        return cls(**values)
    except (TypeError, ValueError, OverflowError) as exc:
        if isinstance(exc, EngineError):
            raise
        raise EngineError(f"{name}: settings: {exc}") from None


TIME_LIMIT = "time limit"


class Iteration(Iterator[tuple[State, StepRecord]]):
    """The (state, record) of each step, made as they are asked for.  ``stopped`` is
    `TIME_LIMIT` once the wall-clock bound ended the iteration, else None (the
    algorithm finished, or ``max_iter`` steps were made: ``steps`` counts them).
    The clock starts at the first request and is read between steps, so at least
    one step is made; a step is never cut short, and the records made are exactly
    a prefix of the run without the limit (the state stays resumable)."""

    def __init__(
        self,
        algorithm: Algorithm,
        problem: Problem,
        settings: Settings,
        max_iter: int,
        state: State | None,
        time_limit: float | None,
    ) -> None:
        self.algorithm, self.problem, self.settings = algorithm, problem, settings
        self.max_iter, self.state, self.time_limit = max_iter, state, time_limit
        self.steps = 0
        self.stopped: str | None = None
        self._began: float | None = None

    def __next__(self) -> tuple[State, StepRecord]:
        if self._began is None:
            self._began = time.perf_counter()
        if self.state is None:
            self.state = self.algorithm.init(self.problem, self.settings)
        if self.stopped is not None or self.state.status.finished or self.steps >= self.max_iter:
            raise StopIteration
        if self.steps and self.time_limit is not None and time.perf_counter() - self._began >= self.time_limit:
            self.stopped = TIME_LIMIT
            raise StopIteration
        self.state, record = self.algorithm.step(self.state)
        self.steps += 1
        return self.state, record


def iterate(
    algorithm: Algorithm,
    problem: Problem,
    settings: Settings,
    *,
    max_iter: int,
    state: State | None = None,
    time_limit: float | None = None,
) -> Iteration:
    """Step (from ``state``, else from ``init``) until the algorithm finishes, ``max_iter``
    steps were made, or ``time_limit`` seconds of wall clock have passed (checked
    between steps; the `Iteration`'s ``stopped`` is then `TIME_LIMIT`)."""
    if time_limit is not None and not time_limit >= 0:
        raise EngineError(f"time limit must be a number of seconds >= 0, not {time_limit!r}")
    return Iteration(algorithm, problem, settings, max_iter, state, time_limit)
