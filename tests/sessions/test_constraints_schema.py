"""``problem.constraints``: the schema field, its build into ``Problem.linear_constraints``,
and every refusal naming its JSON path (and, for a reading error, the column)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from sessions.errors import SessionError
from sessions.format.constraint_lines import check_constraint_line
from sessions.format.limits import MAX_CONSTRAINTS
from sessions.format.schema import ProblemModel
from sessions.runner import run_session
from sessions.store import load_session

EXAMPLES = Path(__file__).resolve().parents[2] / "sessions" / "examples"
STAMP = "2026-01-01T00:00:00+00:00"


def two_conditions(constraints: list[str]) -> dict:
    """A lead compensator on 10/(s(s+1)(s+5)) in two conditions: K per condition, T1 and T2 shared."""

    def condition(name: str) -> dict:
        blocks = [
            {
                "name": "lead",
                "input": "e",
                "output": "u",
                "transfer": {"kind": "expression", "expression": "K*(1 + T1*s)/(1 + T2*s)"},
            },
            {
                "name": "plant",
                "input": "u",
                "output": "y",
                "transfer": {"kind": "expression", "expression": "10/(s*(s + 1)*(s + 5))"},
            },
        ]
        return {
            "name": name,
            "break_at": "e",
            "plant": {
                "format": "diagram",
                "inputs": ["r"],
                "blocks": blocks,
                "junctions": [{"name": "sum", "output": "e", "plus": ["r"], "minus": ["y"]}],
            },
        }

    problem = {
        "grid": {"start": 0.01, "stop": 100.0, "points": 100},
        "conditions": [condition("cruise"), condition("climb")],
        "parameters": [
            {"name": "K", "value": [1.0, 2.0], "min": 0.1},
            {"name": "T1", "value": 0.5, "min": 0.01},
            {"name": "T2", "value": 0.1, "min": 0.01},
            {"name": "G", "value": 3.0, "free": False},
        ],
        "targets": [{"measure": "phase_margin_deg", "bands": [{"desired": 50.0}]}],
        "constraints": constraints,
    }
    return {
        "schema_version": 2,
        "provenance": {"loopcraft_version": "0.1.0", "created": STAMP, "modified": STAMP},
        "problem": problem,
        "algorithm": {"name": "slp", "settings": {}},
    }


def load(tmp_path: Path, doc: dict):
    path = tmp_path / "s.json"
    path.write_text(json.dumps(doc))
    return load_session(path)


def refused(tmp_path: Path, doc: dict) -> str:
    with pytest.raises(SessionError) as caught:
        load(tmp_path, doc)
    return str(caught.value)


def test_rows_over_the_free_vector(tmp_path):
    """Free vector (K[cruise], K[climb], T1, T2); G fixed at 3 moves into b; K without a
    condition gives one row per condition, K[climb] / K[0] pick one."""
    session = load(tmp_path, two_conditions(["T1 >= 4*T2", "K + 2*T1 <= G + 10", "K[climb] - K[0] <= 1.5"]))
    A, b = session.problem.linear_constraints
    assert np.array_equal(A, [[0, 0, -1, 4], [1, 0, 2, 0], [0, 1, 2, 0], [-1, 1, 0, 0]])
    assert np.array_equal(b, [0, 13, 13, 1.5])
    assert session.model.problem.constraints[0] == "T1 >= 4*T2"  # kept as written


@pytest.mark.parametrize(
    "line, message",
    [
        ("K*T1 <= 10", "problem.constraints[1]: not linear: a product of parameters (K and T1) at column 2"),
        ("T1 >= 4T2", "problem.constraints[1]: unexpected 'T2' (a missing operator?) at column 8"),
        ("X + T1 <= 2", "problem.constraints[1]: unknown parameter 'X'"),
        ("T1[cruise] <= 2", "problem.constraints[1]: 'T1' is shared by all conditions"),
        ("K[descent] <= 2", "problem.constraints[1]: K[descent]: no condition 'descent'"),
        ("T1 <= 4*T2", "problem.constraints[1]: 'T1 <= 4*T2' is not met at the start: violated by 0.1"),
        ("K <= 1.5", "problem.constraints[1]: 'K <= 1.5' is not met in condition 'climb' at the start"),
        ("G >= 4", "problem.constraints[1]: 'G >= 4' is not met at the start"),
    ],
)
def test_refusals_name_the_path(tmp_path, line, message):
    assert message in refused(tmp_path, two_conditions(["T1 >= 4*T2", line]))


def test_limits(tmp_path):
    doc = two_conditions(["T1 >= 4*T2"] * (MAX_CONSTRAINTS + 1))
    assert "problem.constraints: List should have at most 1000 items" in refused(tmp_path, doc)
    doc = two_conditions(["T1 + " * 250 + "T2 <= 1e6"])
    assert "problem.constraints[0]: String should have at most 1000 characters" in refused(tmp_path, doc)
    doc = two_conditions([17])
    assert "problem.constraints[0]: Input should be a valid string" in refused(tmp_path, doc)


def test_the_editor_check():
    model = ProblemModel.model_validate(two_conditions(["T1 >= 4*T2"])["problem"])
    assert check_constraint_line("T1 <= 20*T2", model).bound == 0.0
    with pytest.raises(SessionError, match=r"problem.constraints\[1\]: .* at column 4"):
        check_constraint_line("T1 > 4*T2", model)
    with pytest.raises(SessionError, match=r"problem.constraints\[0\]: 'K <= 1.5' is not met in condition 'climb'"):
        check_constraint_line("K <= 1.5", model, 0)
    with pytest.raises(SessionError, match=r"problem.constraints\[1\]: unknown parameter 'k'"):
        check_constraint_line("k <= 1.5", model)


def test_projection_refuses_them(tmp_path):
    doc = json.loads((EXAMPLES / "projection_integrator.json").read_text())
    doc["problem"]["parameters"] = [{"name": "a", "value": 1.0}]
    doc["problem"]["constraints"] = ["a <= 2"]
    session = load(tmp_path, doc)
    with pytest.raises(SessionError, match="projection: linear constraints between parameters"):
        run_session(session, 1, autosave=False)


def test_without_constraints_nothing_changes():
    """An existing session: no field, no rows, the report's behaviour."""
    session = load_session(EXAMPLES / "report003_lag_lead.json")
    A, b = session.problem.linear_constraints
    assert A.shape == (0, 4) and b.shape == (0,)
    assert "constraints" not in json.loads((EXAMPLES / "report003_lag_lead.json").read_text())["problem"]
    assert session.model.problem.constraints == []
