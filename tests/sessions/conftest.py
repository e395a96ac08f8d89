import copy
import json

import pytest

MATCHING = {
    "schema_version": 2,
    "provenance": {
        "loopcraft_version": "0.1.0",
        "created": "2026-11-23T00:00:00+00:00",
        "modified": "2026-11-23T00:00:00+00:00",
    },
    "notes": "model matching by steepest descent (the tests' algorithm)",
    "algorithm": {"name": "gradient", "settings": {"step": 1.0}},
    "problem": {
        "grid": {"unit": "rad/s", "start": 0.1, "stop": 100.0, "points": 60, "spacing": "log"},
        "conditions": [
            {
                "name": "nominal",
                "break_at": "e",
                "plant": {
                    "format": "diagram",
                    "inputs": ["r"],
                    "blocks": [
                        {
                            "name": "C",
                            "input": "e",
                            "output": "u",
                            "transfer": {"kind": "expression", "expression": "K*(1+T*s)"},
                        },
                        {
                            "name": "P",
                            "input": "u",
                            "output": "y",
                            "transfer": {"kind": "factored", "s_power": -1, "poles": [{"kind": "root", "a": 2.0}]},
                        },
                    ],
                    "junctions": [{"name": "sum", "output": "e", "plus": ["r"], "minus": ["y"]}],
                },
            }
        ],
        "parameters": [{"name": "K", "value": 1.0, "min": 0.0}, {"name": "T", "value": 0.1}],
        "targets": [
            {"measure": "phase_margin_deg", "bands": [{"desired": 45.0}]},
            {"measure": "stability_margin", "bands": [{"desired": 0.5}]},
        ],
        "objective": {"kind": "match", "options": {"reference": "4*(1+0.5*s)/(s*(s+2))"}},
    },
    "records": [],
    "current_iteration": 0,
    "state": None,
}


@pytest.fixture
def matching(tmp_path):
    path = tmp_path / "matching.json"
    path.write_text(json.dumps(MATCHING, indent=2))
    return path


@pytest.fixture
def matching_dict():
    return copy.deepcopy(MATCHING)
