"""Each algorithm's memory: a frozen class that round-trips through JSON, and
whose ``from_json`` rejects corrupted data naming the field."""

from __future__ import annotations

import copy
import dataclasses
import json
from pathlib import Path

import pytest

from engine.errors import EngineError
from engine.stepping.memory_fields import jsonable
from engine.stepping.protocol import State
from engine.stepping.registry import lookup, make_settings
from sessions.store import load_session

EXAMPLES = Path(__file__).resolve().parents[2] / "sessions" / "examples"
SESSIONS = {
    "cip": "cip_launch_vehicle.json",
    "qcg": "seidel_inlet_pi.json",
    "slp": "coebra_lag_lead.json",
    "projection": "projection_integrator.json",
}


def stepped(name: str) -> State:
    """The state after one step of an example session's algorithm."""
    session = load_session(EXAMPLES / SESSIONS[name])
    stepper = lookup(name).bind(session.problem, make_settings(name, session.model.algorithm.settings))
    return stepper.step(stepper.init())[0]


@pytest.fixture(scope="module")
def states() -> dict[str, State]:
    return {name: stepped(name) for name in SESSIONS}


@pytest.mark.parametrize("name", sorted(SESSIONS))
def test_memory_is_frozen_and_round_trips(states, name):
    state = states[name]
    memory_type = lookup(name).memory_type
    assert isinstance(state.memory, memory_type) and dataclasses.is_dataclass(state.memory)
    with pytest.raises(dataclasses.FrozenInstanceError):
        state.memory.__setattr__(dataclasses.fields(state.memory)[0].name, None)
    text = json.dumps(state.to_json(), allow_nan=False)  # plain JSON: non-finite numbers are strings
    again = State.from_json(json.loads(text), memory_type)
    assert again.to_json() == state.to_json()
    if getattr(memory_type, "PLAIN_JSON", False):  # the guard then reads it back as it is
        assert jsonable(state.memory.to_json()) == state.memory.to_json()
        json.dumps(state.memory.to_json(), allow_nan=False)


def _set(path: str, value):
    """A corruption: set (or, with ..., delete) the item at a dotted path of the memory."""

    def corrupt(data: dict) -> None:
        *parents, last = path.split(".")
        for part in parents:
            data = data[int(part)] if isinstance(data, list) else data[part]
        key = int(last) if isinstance(data, list) else last
        if value is ...:
            del data[key]
        else:
            data[key] = value

    return corrupt


def _shorten(path: str):
    def corrupt(data: dict) -> None:
        *parents, last = path.split(".")
        for part in parents:
            data = data[part]
        data[last] = data[last][:-1]

    return corrupt


@pytest.mark.parametrize(
    "name, corrupt, message",
    [
        ("cip", _set("step", "fast"), r"cip memory\.step: expected a finite number, got the string \"fast\""),
        ("cip", _set("requirements.0.desired", ...), r"cip memory\.requirements\[0\]\.desired: missing"),
        ("cip", _set("best.x.0", "nan"), r"cip memory\.best\.x\[0\]: expected a finite number, got nan"),
        (
            "cip",
            _set("requirements.1.kind", "Q"),
            r"cip memory\.requirements\[1\]\.kind: expected one of A, D, G, P, S",
        ),
        ("qcg", _shorten("initial_scale"), r"qcg memory\.initial_scale: expected \d+ items, got \d+"),
        ("qcg", _set("kount", 1.5), r"qcg memory\.kount: expected an integer >= 0, got the number 1\.5"),
        ("slp", _set("P", "inf"), r"slp memory\.P: expected a finite number, got inf"),
        ("slp", _shorten("base.frequencies"), r"slp memory\.base\.frequencies: expected \d+ items, got \d+"),
        ("slp", _set("major", ...), r"slp memory\.major: missing"),
        (
            "slp",
            _set("best.stable", "yes"),
            r"slp memory\.best\.stable: expected true or false, got the string \"yes\"",
        ),
        ("projection", _shorten("r.u"), r"projection memory\.r\.u: expected \d+ items, got \d+"),
        ("projection", _set("distances", ["1.0"]), r"projection memory\.distances\[0\]: expected a finite number"),
        ("projection", _set("r.x.0", 3.0), r"projection memory\.r\.x\[0\]: expected a list, got the number 3\.0"),
    ],
)
def test_corrupt_memory_is_rejected_naming_the_field(states, name, corrupt, message):
    data = copy.deepcopy(states[name].to_json())
    corrupt(data["memory"])
    with pytest.raises(EngineError, match=message):
        State.from_json(data, lookup(name).memory_type)


@pytest.mark.parametrize(
    "change, message",
    [
        (("status", "asleep"), r"state\.status: expected one of running, .*, got 'asleep'"),
        (("x", [1.0, "two"]), r"state\.x\[1\]: expected a finite number, got the string \"two\""),
        (("memory", [1, 2]), r"slp memory: expected an object, got a list"),
    ],
)
def test_corrupt_state_is_rejected_naming_the_field(states, change, message):
    data = dict(states["slp"].to_json(), **dict([change]))
    with pytest.raises(EngineError, match=message):
        State.from_json(data, lookup("slp").memory_type)
