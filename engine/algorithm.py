"""The stepper protocol every design algorithm follows, and its registry.

An algorithm is set up with `init(problem, settings)`, which returns the first
`State`; `step(state)` returns the next state and a `StepRecord` and never
changes its input.  States and records are frozen and convert to and from
JSON (`to_json`/`from_json`), so a session can store them and replay them.
"""

from __future__ import annotations

import copy
import importlib
import dataclasses
import math
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass, field
from enum import Enum
from typing import Any, Protocol

from .errors import EngineError
from .problem import Problem


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
    target: float | None
    satisfied: bool
    frequency: float | None = None
    at_least: bool = True   # larger values are better (False: peaks, times, errors, attenuation)
    method: str | None = None  # margins: "refined", "fitted (residual ...)" or "grid"


def _jsonable(value: Any) -> Any:
    """Plain JSON types; non-finite floats become the strings 'inf', '-inf', 'nan'."""
    if isinstance(value, float):
        return value if math.isfinite(value) else repr(value)
    if isinstance(value, Enum):
        return value.value
    if isinstance(value, Mapping):
        return {str(k): _jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_jsonable(v) for v in value]
    if hasattr(value, "tolist"):
        return _jsonable(value.tolist())
    return value


def _number(value: Any) -> Any:
    if isinstance(value, str) and value in ("inf", "-inf", "nan"):
        return float(value)
    return value


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
    extra: Mapping[str, Any] = field(default_factory=dict)

    def to_json(self) -> dict:
        data = {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}
        data["measures"] = [dataclasses.asdict(m) for m in self.measures]
        return _jsonable(data)

    @staticmethod
    def from_json(data: Mapping[str, Any]) -> StepRecord:
        measures = tuple(MeasureRow(**{k: _number(v) for k, v in m.items()}) for m in data["measures"])
        return StepRecord(
            iteration=int(data["iteration"]), status=Status(data["status"]),
            parameters={k: (list(map(_number, v)) if isinstance(v, list) else _number(v))
                        for k, v in data["parameters"].items()},
            measures=measures, objective=_number(data.get("objective")),
            step_size=_number(data.get("step_size")),
            direction=tuple(_number(v) for v in data.get("direction", ())),
            counters=dict(data.get("counters", {})), reason=data.get("reason", ""),
            extra=dict(data.get("extra", {})))


@dataclass(frozen=True)
class State:
    """An algorithm's state between iterations: the free vector, its status,
    and algorithm-specific memory (JSON types only)."""

    iteration: int
    x: tuple[float, ...]
    status: Status = Status.RUNNING
    memory: Mapping[str, Any] = field(default_factory=dict)

    def to_json(self) -> dict:
        return _jsonable({"iteration": self.iteration, "x": self.x, "status": self.status,
                          "memory": self.memory})

    @staticmethod
    def from_json(data: Mapping[str, Any]) -> State:
        return State(int(data["iteration"]), tuple(float(_number(v)) for v in data["x"]),
                     Status(data["status"]), copy.deepcopy(dict(data.get("memory", {}))))


class Algorithm(Protocol):
    """The stepper protocol (docs/architecture.md): `init` binds the problem and settings."""

    name: str

    def init(self, problem: Problem, settings: Any) -> State: ...

    def step(self, state: State) -> tuple[State, StepRecord]: ...


@dataclass(frozen=True)
class Registration:
    """An algorithm's factory, its settings class (a dataclass with defaults) and a summary."""

    factory: Callable[[], Algorithm]
    settings: type
    summary: str
    maximize: bool = False  # its record's objective is better larger (sweeps rank runs by it)


REGISTRY: dict[str, Registration] = {}
BUILTIN = (".cip", ".qcg", ".slp", ".projection")  # packages that register the report algorithms when imported


def load_builtin() -> dict[str, Registration]:
    """Import the bundled algorithms (they register themselves); the registry."""
    for module in BUILTIN:
        importlib.import_module(module, __package__)
    return REGISTRY


def register(name: str, factory: Callable[[], Algorithm], settings: type, summary: str,
             maximize: bool = False) -> None:
    """Make an algorithm known to the CLI and the app by name."""
    REGISTRY[name] = Registration(factory, settings, summary, maximize)


def lookup(name: str) -> Registration:
    load_builtin()
    if name not in REGISTRY:
        known = ", ".join(sorted(REGISTRY)) or "none yet"
        raise EngineError(f"unknown algorithm {name!r} (known: {known})")
    return REGISTRY[name]


def make_settings(name: str, values: Mapping[str, Any]) -> Any:
    """The algorithm's settings from a mapping; unknown names are an error."""
    cls = lookup(name).settings
    names = {f.name for f in dataclasses.fields(cls)}
    unknown = sorted(set(values) - names)
    if unknown:
        raise EngineError(f"{name}: unknown setting(s) {', '.join(unknown)}; "
                          f"settings are {', '.join(sorted(names))}")
    return cls(**values)


def iterate(algorithm: Algorithm, problem: Problem, settings: Any, *, max_iter: int,
            state: State | None = None) -> Iterator[tuple[State, StepRecord]]:
    """Step until the algorithm finishes or ``max_iter`` iterations were made."""
    state = algorithm.init(problem, settings) if state is None else state
    for _ in range(max_iter):
        if state.status.finished:
            return
        state, record = algorithm.step(state)
        yield state, record
