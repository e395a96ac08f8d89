"""The algorithms loopcraft knows, found through Python entry points.

An algorithm is a package that declares one `Registration` under the entry-point
group ``loopcraft.algorithms`` (the bundled four in loopcraft's pyproject.toml, a
plug-in in its own): the CLI, the app and the sweeps' Dask workers all find it
there, and nothing else names it.  A registration says how to bind the algorithm
to a problem, its settings, how its records are shown, which target measures it
reads, and whether the new-session dialog offers it.  An entry point is loaded on
first use (a session of one algorithm imports no other).
"""

from __future__ import annotations

import dataclasses
import functools
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from importlib.metadata import EntryPoint, entry_points

from engine.design.measure_kinds import TargetUse
from engine.design.problem import Problem
from engine.errors import EngineError
from engine.stepping.presenter import Presenter
from engine.stepping.protocol import Memory, Settings, Stepper

GROUP = "loopcraft.algorithms"


@dataclass(frozen=True)
class Registration:
    """An algorithm as loopcraft knows it.

    ``bind(problem, settings)`` gives its frozen `Stepper`; ``settings`` is its settings
    class (a dataclass with a default for every field); ``memory_type`` reads its stored
    memory back; ``presenter`` shows its records; ``targets`` says which target measures
    it reads; ``new_session_rank``: offered for a new session (lowest first, the
    default) or not (None)."""

    name: str
    bind: Callable[[Problem, Settings], Stepper]
    settings: type[Settings]
    memory_type: type[Memory]
    summary: str
    presenter: Presenter = dataclasses.field(default_factory=Presenter)
    targets: TargetUse = TargetUse()
    new_session_rank: int | None = None


@functools.cache
def _entry_points() -> dict[str, EntryPoint]:
    return {point.name: point for point in entry_points(group=GROUP)}


def known() -> list[str]:
    """The names of every algorithm installed, sorted."""
    return sorted(_entry_points())


@functools.cache
def lookup(name: str) -> Registration:
    """The registration of the algorithm ``name`` (its package imported on first use)."""
    point = _entry_points().get(name)
    if point is None:
        raise EngineError(f"unknown algorithm {name!r} (known: {', '.join(known())})")
    try:
        found = point.load()
    except Exception as exc:  # noqa: BLE001 - a broken plug-in is named, never a traceback
        raise EngineError(f"algorithm {name!r}: its package fails to load ({type(exc).__name__}: {exc})") from None
    if not isinstance(found, Registration) or found.name != name:
        raise EngineError(f"algorithm {name!r}: its entry point {point.value} is not its Registration")
    return found


def registrations() -> dict[str, Registration]:
    """Every installed algorithm's registration (each package imported), by name."""
    return {name: lookup(name) for name in known()}


def new_session_algorithms() -> list[str]:
    """The algorithms a new session may use, the default first."""
    offered = [(r.new_session_rank, name) for name, r in registrations().items() if r.new_session_rank is not None]
    return [name for _, name in sorted(offered)]


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


def bind(name: str, problem: Problem, values: Mapping[str, object]) -> Stepper:
    """The algorithm ``name`` bound to ``problem`` with settings from ``values``."""
    return lookup(name).bind(problem, make_settings(name, values))
