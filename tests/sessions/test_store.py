"""Sessions: round trips, error messages with JSON paths, versions, atomic
saves, autosave, and the stepper protocol through the tests' algorithm."""

from __future__ import annotations

import copy
import json
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import sessions.store as store
from engine.stepping.driver import iterate
from engine.stepping.protocol import State
from engine.stepping.registry import lookup, make_settings
from sessions.errors import SessionError
from sessions.format import migrations
from sessions.format.json_schema import SCHEMA_FILE, schema_text
from sessions.format.schema import SweepModel
from sessions.runner import replay, run_session
from sessions.store import autosave_candidate, autosave_path, dumps, load_session, parse_session, save_session

EXAMPLES = sorted((Path(__file__).resolve().parents[2] / "sessions" / "examples").glob("*.json"))


@pytest.mark.parametrize("example", EXAMPLES, ids=lambda p: p.name)
def test_examples_round_trip_to_equal_sessions_and_stable_json(example, tmp_path):
    for table in example.parent.glob("*.csv"):
        shutil.copy2(table, tmp_path / table.name)
    first = load_session(example)
    saved = save_session(first, tmp_path / example.name)
    again = load_session(saved)
    assert again.model.problem == first.model.problem and again.model.records == first.model.records
    text = saved.read_text()
    assert json.loads(text) == json.loads(dumps(again.model))  # before saving again stamps a new time
    save_session(again, tmp_path / "again.json")
    assert (tmp_path / "again.json").read_text().replace(again.model.provenance.modified, "") == text.replace(
        json.loads(text)["provenance"]["modified"], ""
    )


def test_saving_elsewhere_keeps_csv_tables_reachable(tmp_path):
    session = load_session(EXAMPLES[0].parent / "cip_launch_vehicle.json")
    (tmp_path / "deeper").mkdir()
    saved = save_session(session, tmp_path / "deeper" / "copy.json")
    again = load_session(saved)
    assert again.model.problem.conditions[0].plant.channels[0].response.table.csv.endswith("cip_launch_vehicle.csv")
    assert np.allclose(again.problem.grid.omega, session.problem.grid.omega)


def test_json_schema_file_is_current():
    assert SCHEMA_FILE.read_text() == schema_text(), "run: python -m sessions.format.json_schema"


@pytest.mark.parametrize(
    "change, message",
    [
        (
            lambda d: d["problem"]["conditions"][0]["plant"]["blocks"][1]["transfer"].update(
                poles=[{"kind": "second_order", "zeta": -0.1, "omega": 3.0}]
            ),
            r"problem\.conditions\[0\]\.plant\.blocks\[1\]\.transfer\.poles\[0\]: zeta: must be > 0",
        ),
        (
            lambda d: d["problem"]["conditions"][0]["plant"]["blocks"][0]["transfer"].update(expression="K*(1+T s)"),
            r"problem\.conditions\[0\]\.plant\.blocks\[0\]\.transfer: a missing operator .* at column 4",
        ),
        (
            lambda d: d["problem"]["conditions"][0]["plant"]["blocks"][0].update(input="ee"),
            r"problem\.conditions\[0\]: block 'C' reads signal 'ee'",
        ),
        (lambda d: d["problem"]["grid"].update(stop=0.01), r"problem\.grid: stop must be greater than start"),
        (lambda d: d["problem"].update(colour="blue"), r"problem\.colour: Extra inputs are not permitted"),
        (lambda d: d["problem"]["parameters"].pop(), r"no parameter defined for T"),
        (lambda d: d.update(schema_version=7), r"schema_version 7 is newer than this loopcraft reads"),
        (lambda d: d.pop("schema_version"), r"schema_version: missing"),
    ],
)
def test_errors_name_the_json_path(matching_dict, tmp_path, change, message):
    change(matching_dict)
    path = tmp_path / "bad.json"
    path.write_text(json.dumps(matching_dict))
    before = path.read_bytes()
    with pytest.raises(SessionError, match=message):
        load_session(path)
    assert path.read_bytes() == before


def test_syntax_errors_give_line_and_column(tmp_path):
    path = tmp_path / "broken.json"
    path.write_text('{\n  "schema_version": 1,\n  "notes": oops\n}')
    with pytest.raises(SessionError, match=r"broken.json: line 3, column 12"):
        load_session(path)


def test_older_versions_are_migrated_and_say_so(matching_dict, tmp_path, monkeypatch):
    def from_0(data):  # version 0 called the notes "comment"
        data["notes"] = data.pop("comment")
        return data

    monkeypatch.setitem(migrations.MIGRATIONS, 0, from_0)
    matching_dict["schema_version"] = 0
    matching_dict["comment"] = matching_dict.pop("notes")
    path = tmp_path / "old.json"
    path.write_text(json.dumps(matching_dict))
    session = load_session(path)
    assert session.messages == ["migrated from schema version 0 to 1", "migrated from schema version 1 to 2"]
    assert session.model.notes.startswith("model matching")


def test_save_keeps_a_backup_and_autosave_is_offered_when_newer(matching, tmp_path):
    session = load_session(matching)
    original = matching.read_text()
    run_session(session, iterations=2)
    assert autosave_candidate(matching) == autosave_path(matching)
    assert json.loads(autosave_path(matching).read_text())["current_iteration"] == 2
    save_session(session)
    assert Path(str(matching) + ".bak").read_text() == original
    assert autosave_candidate(matching) is None
    assert load_session(matching).model.current_iteration == 2


def test_gradient_algorithm_descends_and_replay_reproduces(matching):
    session = load_session(matching)
    records = run_session(session, until_done=True, autosave=False)
    objectives = [r.objective for r in records]
    assert all(b < a for a, b in zip(objectives[:-1], objectives[1:-1]))
    assert records[-1].status.value == "converged" and objectives[-1] < 1e-24
    final = records[-1].parameters
    assert final["K"] == pytest.approx(4.0, rel=1e-3) and final["T"] == pytest.approx(0.5, rel=1e-3)
    save_session(session)
    result = replay(load_session(matching))
    assert result.ok and result.iterations == len(records)


def test_replay_names_the_first_altered_iteration(matching):
    session = load_session(matching)
    run_session(session, iterations=4, autosave=False)
    session.model.records[2]["parameters"]["K"] *= 1 + 1e-7
    save_session(session)
    result = replay(load_session(matching))
    assert not result.ok and result.iterations == 3
    assert "iteration 3 diverges: parameter K" in result.message


def test_step_never_mutates_its_input(matching):
    session = load_session(matching)
    algorithm = lookup("gradient").bind(session.problem, make_settings("gradient", {}))
    state = algorithm.init()
    frozen = json.dumps(state.to_json(), sort_keys=True)
    new, record = algorithm.step(state)
    assert json.dumps(state.to_json(), sort_keys=True) == frozen
    assert new.iteration == 1 and State.from_json(json.loads(json.dumps(new.to_json())), algorithm.memory_type) == new
    assert record.to_json() == type(record).from_json(json.loads(json.dumps(record.to_json()))).to_json()
    steps = list(iterate(algorithm, max_iter=3))
    assert [s.iteration for s, _ in steps] == [1, 2, 3]


KILLER = r"""
import sys, time
from sessions.store import load_session, save_session
s = load_session(sys.argv[1])
s.model.notes = "x" * 2_000_000
print("ready", flush=True)
i = 0
while True:
    i += 1
    s.model.notes = str(i % 10) * 2_000_000
    save_session(s)
"""


@pytest.mark.slow
def test_a_killed_save_leaves_the_old_or_the_new_file(matching):
    for delay in (0.05, 0.2, 0.45):
        proc = subprocess.Popen(
            [sys.executable, "-c", KILLER, str(matching)],
            stdout=subprocess.PIPE,
            cwd=Path(__file__).resolve().parents[2],
        )
        assert proc.stdout.readline().strip() == b"ready"
        import time

        time.sleep(delay)
        proc.kill()
        proc.wait()
        proc.stdout.close()
        notes = load_session(matching).model.notes  # parses: never a broken file
        assert notes.startswith("model matching") or len(set(notes)) == 1
    save_session(load_session(matching))  # the next save sweeps temporary files of killed saves
    assert [p for p in matching.parent.iterdir() if p.name.endswith(".tmp")] == []


def test_grid_units_are_kept(matching_dict, tmp_path):
    matching_dict["problem"]["grid"].update(unit="hz", start=0.1, stop=10.0)
    path = tmp_path / "hz.json"
    path.write_text(json.dumps(matching_dict))
    grid = load_session(path).problem.grid
    assert grid.unit == "hz"
    np.testing.assert_allclose(grid.omega[[0, -1]], [2 * np.pi * 0.1, 2 * np.pi * 10.0])


def test_csv_table_next_to_the_session(matching_dict, tmp_path):
    """The inlet data of report 001 as a CSV block; a bad cell names its line and column."""
    shared = Path(__file__).resolve().parents[2] / "sessions" / "examples" / "seidel_inlet_table1.csv"
    (tmp_path / "inlet.csv").write_text(shared.read_text())
    plant = matching_dict["problem"]["conditions"][0]["plant"]
    plant["blocks"][1]["transfer"] = {
        "kind": "table",
        "table": {"unit": "hz", "gain": 0.016, "csv": "inlet.csv", "columns": ["hz", "g1_mag", "g1_phase_deg"]},
    }
    matching_dict["problem"]["grid"] = {"unit": "hz", "start": 1.0, "stop": 600.0, "points": 50}
    path = tmp_path / "inlet.json"
    path.write_text(json.dumps(matching_dict))
    table = load_session(path).problem.conditions[0].network.entries[1].transfer.table
    assert abs(table.interpolate([2 * np.pi * 60])[0]) == pytest.approx(0.016 * 0.326)
    lines = (tmp_path / "inlet.csv").read_text().splitlines(keepends=True)
    bad = next(i for i, line in enumerate(lines) if line.startswith("60,"))
    lines[bad] = lines[bad].replace("0.326,-55", "0.326,oops")
    (tmp_path / "inlet.csv").write_text("".join(lines))
    with pytest.raises(SessionError, match=rf"inlet.csv: line {bad + 1}, column 'g1_phase_deg': not a number: 'oops'"):
        load_session(path)


def test_autosave_during_a_run_is_throttled_and_written_at_its_end(matching):
    session = load_session(matching)
    assert store.write_autosave(session, at_most_every=60.0) is not None  # the first one is written
    assert store.write_autosave(session, at_most_every=60.0) is None  # the next within 60 s is not
    run_session(session, iterations=3)
    assert json.loads(autosave_path(matching).read_text())["current_iteration"] == 3  # the end of the run is


def test_a_version_1_session_reads_as_it_was_saved(tmp_path):
    """Version 2 renamed saved names (sessions/format/migrations.py): a session saved by
    version 1, written here by renaming a version-2 save's keys back, loads to the same
    model, records, state and sweep."""
    source = Path(__file__).resolve().parents[2] / "sessions" / "examples" / "cip_launch_vehicle.json"
    path = tmp_path / "lv.json"
    shutil.copy(source, path)
    shutil.copy(source.with_suffix(".csv"), tmp_path / source.with_suffix(".csv").name)
    session = load_session(path)
    session.model.problem.targets[0].requirement = False
    assert len(run_session(session, 2, autosave=False)) == 2
    session.model.sweeps.append(
        SweepModel(
            version=2,
            kind="starts",
            created="x",
            algorithm="cip",
            runs=[{"index": 0, "ranking": 1.5, "measures": [{"name": "G1", "desired": 0.5}]}],
            optima=[{"ranking": 1.5, "count": 1}],
            worst_case=[{"name": "G1", "desired": 0.5, "worst": 0.2}],
        )
    )
    save_session(session)
    saved = json.loads(path.read_text())

    old = copy.deepcopy(saved)
    old["schema_version"] = 1
    old["problem"]["targets"][0]["constraint"] = old["problem"]["targets"][0].pop("requirement")
    for record in old["records"]:
        for row in record["measures"]:
            row["target"] = row.pop("desired")
    old["state"]["memory"]["constraints"] = old["state"]["memory"].pop("requirements")
    sweep = old["sweeps"][0]
    sweep["version"] = 1
    sweep["runs"][0]["objective"] = sweep["runs"][0].pop("ranking")
    sweep["runs"][0]["measures"][0]["target"] = sweep["runs"][0]["measures"][0].pop("desired")
    sweep["optima"][0]["objective"] = sweep["optima"][0].pop("ranking")
    sweep["worst_case"][0]["target"] = sweep["worst_case"][0].pop("desired")
    path.write_text(json.dumps(old))

    migrated = load_session(path)
    assert migrated.messages == ["migrated from schema version 1 to 2"]
    assert migrated.model == load_session_text(saved, tmp_path).model
    assert migrated.state == session.state and migrated.records == session.records


def load_session_text(data: dict, folder: Path):
    return parse_session(json.dumps(data), "saved", folder)
