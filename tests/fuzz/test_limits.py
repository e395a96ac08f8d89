"""The classes of failure the fuzzer found, pinned: sessions at the schema's
size limits finish `report` in seconds, sessions beyond them are refused at
load naming the path, and the representative mutants of the issue end in a
clean error (exit status 2, one message) with no RuntimeWarning."""

from __future__ import annotations

import contextlib
import copy
import io
import json
import time
import warnings
from pathlib import Path

import pytest

from engine.errors import ExpressionError
from engine.model.expressions import Expression
from sessions.format import limits
from tui.cli import main

EXAMPLES = Path(__file__).resolve().parents[2] / "sessions" / "examples"
LAG_LEAD = json.loads((EXAMPLES / "report003_lag_lead.json").read_text())


def _cli(path: Path, *argv: str) -> tuple[int, str, list[str]]:
    out, err = io.StringIO(), io.StringIO()
    with (
        warnings.catch_warnings(record=True) as caught,
        contextlib.redirect_stdout(out),
        contextlib.redirect_stderr(err),
    ):
        warnings.simplefilter("always")
        status = main([argv[0], str(path), *argv[1:]])
    return status, err.getvalue(), [str(w.message) for w in caught if issubclass(w.category, RuntimeWarning)]


def _chain(doc: dict, count: int) -> dict:
    plant = doc["problem"]["conditions"][0]["plant"]
    first, rest = plant["blocks"][0], plant["blocks"][1:]
    first["output"] = "g0"
    chain = [
        {
            "name": f"g{i}",
            "input": f"g{i}",
            "output": f"g{i + 1}",
            "transfer": {"kind": "expression", "expression": "1"},
        }
        for i in range(count - len(rest) - 1)
    ]
    chain[-1]["output"] = "u"
    plant["blocks"] = [first, *chain, *rest]
    return doc


def _conditions(doc: dict, count: int) -> dict:
    c = doc["problem"]["conditions"][0]
    doc["problem"]["conditions"] = [dict(copy.deepcopy(c), name=f"c{i}") for i in range(count)]
    return doc


def _targets(doc: dict, count: int) -> dict:
    t = doc["problem"]["targets"]
    doc["problem"]["targets"] = [copy.deepcopy(t[i % len(t)]) for i in range(count)]
    return doc


def _bands(doc: dict, count: int) -> dict:
    for t in doc["problem"]["targets"]:
        desired = t["bands"][0]["desired"]
        t["bands"] = [{"low": float(i), "high": i + 1.0, "desired": desired} for i in range(count - 1)] + [
            {"low": float(count - 1), "desired": desired}
        ]
    return doc


def _junction(doc: dict, count: int) -> dict:
    junction = doc["problem"]["conditions"][0]["plant"]["junctions"][0]
    junction["plus"], junction["minus"] = ["r"] * count, ["y"] * count
    return doc


SIZES = [
    (_chain, limits.MAX_BLOCKS, "blocks"),
    (_conditions, limits.MAX_CONDITIONS, "conditions"),
    (_targets, limits.MAX_TARGETS, "targets"),
    (_bands, limits.MAX_BANDS, "bands"),
    (_junction, limits.MAX_JUNCTION_INPUTS, "plus"),
]


@pytest.mark.parametrize("grow, limit, field", SIZES, ids=[s[2] for s in SIZES])
def test_at_a_limit_report_is_quick_and_beyond_it_the_load_refuses(grow, limit, field, tmp_path):
    at, beyond = tmp_path / "at.json", tmp_path / "beyond.json"
    at.write_text(json.dumps(grow(copy.deepcopy(LAG_LEAD), limit)))
    beyond.write_text(json.dumps(grow(copy.deepcopy(LAG_LEAD), limit + 1)))
    began = time.perf_counter()
    status, err, caught = _cli(at, "report")
    assert (status, caught) == (0, []), err
    assert time.perf_counter() - began < 10
    status, err, _ = _cli(beyond, "report")
    assert status == 2 and field in err and f"at most {limit}" in err


def _block(doc: dict, transfer: dict) -> dict:
    doc["problem"]["conditions"][0]["plant"]["blocks"][0]["transfer"] = transfer
    return doc


MUTANTS = {
    "s/s as a coefficient": {
        "kind": "polynomial",
        "numerator": ["s/s", 1.0],
        "denominator": [1.0, 1.0],
        "order": "ascending",
    },
    "an expression as a coefficient": {
        "kind": "polynomial",
        "numerator": ["2*z1"],
        "denominator": [1.0],
        "order": "ascending",
    },
    "NaN coefficient": {"kind": "factored", "gain": "nan"},
    "deep minus": {"kind": "expression", "expression": "-" * 900 + "s"},
    "long sum": {"kind": "expression", "expression": "s" + "+s" * 500},
    "huge exponent": {"kind": "expression", "expression": "s**1" + "0" * 400},
    "a huge delay": {"kind": "delay", "tau": 1e300},
    "an infinite constant": {"kind": "expression", "expression": "1e308*1e308"},
}


@pytest.mark.parametrize("name", MUTANTS)
@pytest.mark.parametrize("command", ["report", "run"])
def test_representative_mutants_end_in_a_clean_error(name, command, tmp_path):
    path = tmp_path / "mutant.json"
    path.write_text(json.dumps(_block(copy.deepcopy(LAG_LEAD), MUTANTS[name])))
    before = path.read_bytes()
    argv = ("run", "--iterations", "3", "--out", str(tmp_path / "out.json")) if command == "run" else ("report",)
    status, err, caught = _cli(path, *argv)
    assert status in (0, 2) and caught == [] and path.read_bytes() == before
    assert status == 0 or (err.count("\n") == 1 and "error:" in err)


def test_settings_of_the_wrong_type_are_named(tmp_path):
    doc = copy.deepcopy(LAG_LEAD)
    doc["algorithm"]["settings"]["max_step"] = None
    path = tmp_path / "settings.json"
    path.write_text(json.dumps(doc))
    status, err, _ = _cli(path, "run", "--iterations", "1", "--out", str(tmp_path / "out.json"))
    assert status == 2 and "max_step takes a finite number" in err


@pytest.mark.parametrize(
    "text, result", [("-" * 901 + "s", -1j), ("s" + "+s" * 999, 1000j), ("s" + "*s/s" * 400, 1j), ("+" * 500 + "s", 1j)]
)
def test_long_chains_parse_without_recursion(text, result):
    assert Expression(text).evaluate([1j], {}).value[0] == pytest.approx(result)


@pytest.mark.parametrize(
    "text, message",
    [
        ("(s+" * 150 + "s" + ")" * 150, "nested more than"),
        ("s**1" + "0" * 400, "exceeds 64"),
        ("(" * 300 + "s" + ")" * 300, "too many nested parentheses"),
    ],
)
def test_deep_nesting_is_refused_with_a_message(text, message):
    with pytest.raises(ExpressionError, match=message):
        Expression(text)
