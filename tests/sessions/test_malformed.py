"""Property: loading a malformed or truncated session raises only SessionError
and never touches the file (2000 generated cases)."""

from __future__ import annotations

import json

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from sessions.errors import SessionError
from sessions.store import load_session
from tests.sessions.conftest import MATCHING

VALID = json.dumps(MATCHING, indent=1)
JSON_VALUES = st.recursive(
    st.none() | st.booleans() | st.integers(-(10**6), 10**6) | st.floats(allow_nan=False) | st.text(max_size=8),
    lambda inner: st.lists(inner, max_size=3) | st.dictionaries(st.text(max_size=6), inner, max_size=3),
    max_leaves=6,
)


def _paths(node, prefix=()):
    yield prefix
    if isinstance(node, dict):
        for k, v in node.items():
            yield from _paths(v, prefix + (k,))
    elif isinstance(node, list):
        for i, v in enumerate(node):
            yield from _paths(v, prefix + (i,))


PATHS = list(_paths(MATCHING))[1:]


def _mutate(data, path, action, value):
    doc = json.loads(json.dumps(data))
    parent = doc
    for key in path[:-1]:
        parent = parent[key]
    if action == "delete":
        if isinstance(parent, dict):
            del parent[path[-1]]
        else:
            parent.pop(path[-1])
    else:
        parent[path[-1]] = value
    return json.dumps(doc)


MUTANTS = st.one_of(
    st.integers(0, len(VALID) - 1).map(lambda n: VALID[:n]),
    st.tuples(st.sampled_from(PATHS), st.sampled_from(["delete", "replace"]), JSON_VALUES).map(
        lambda t: _mutate(MATCHING, *t)
    ),
    st.binary(max_size=64).map(lambda b: b.decode("latin-1")),
)


@pytest.mark.long
@pytest.mark.slow
@settings(max_examples=2000, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(text=MUTANTS)
def test_malformed_sessions_raise_only_session_error_and_leave_the_file(tmp_path, text):
    path = tmp_path / "mutant.json"
    path.write_text(text, encoding="utf-8")
    before = path.read_bytes()
    try:
        load_session(path)
    except SessionError as exc:
        assert str(exc)
    assert path.read_bytes() == before


def test_a_g2_quotient_that_overflows_is_a_clean_error_without_warnings(tmp_path):
    """G2 = G1G2/G1 of tables: a quotient that overflows (an edited CSV) is named, no numpy warning."""
    import shutil
    import warnings
    from pathlib import Path

    import pytest

    from sessions.store import load_session

    examples = Path(__file__).resolve().parents[2] / "sessions" / "examples"
    shutil.copy(examples / "seidel_inlet_inner_pi.json", tmp_path / "s.json")
    lines = (examples / "seidel_inlet_table1.csv").read_text().splitlines()
    k = next(i for i, line in enumerate(lines) if not line.startswith("#"))  # the header
    header = [c.strip() for c in lines[k].split(",")]
    cells = lines[k + 1].split(",")
    cells[header.index("g1_mag")], cells[header.index("g1g2_mag")] = "1e-300", "1e300"
    lines[k + 1] = ",".join(cells)
    (tmp_path / "seidel_inlet_table1.csv").write_text("\n".join(lines) + "\n")
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        with pytest.raises(SessionError, match="G1G2/G1 is not finite"):
            load_session(tmp_path / "s.json")
