"""The workbench's model without widgets: the plot data against independent computations."""

from __future__ import annotations

import control as ct
import numpy as np

from sessions.store import load_session
from tui.state.workbench import Workbench


def test_step_response_matches_python_control(workdir):
    bench = Workbench(load_session(workdir / "report003_lag_lead.json"))
    t, y, label = bench.view().step_response()
    name, traces, _ = bench.view().step_plot()
    assert name == label and len(traces) == 1 and traces[0][1] == y and traces[0][2] == "current"
    s = ct.tf("s")
    loop = (s + 1) * (s + 5) / ((s + 0.1) * (s + 50)) * 16000 / (s * (s + 8) * (s + 20))
    _, expected = ct.step_response(ct.feedback(loop, 1), T=np.array(t))
    assert label.startswith("y") and np.allclose(y, expected, atol=1e-8)


def test_loop_curve_is_the_open_loop_and_undo_restores_parameters(workdir):
    bench = Workbench(load_session(workdir / "report003_lag_lead.json"))
    curve = bench.view().loop_curve()
    s = 1j * curve.omega
    expected = (s + 1) * (s + 5) / ((s + 0.1) * (s + 50)) * 16000 / (s * (s + 8) * (s + 20))
    assert np.allclose(curve.gh, expected, rtol=1e-12)
    bench2 = Workbench(load_session(workdir / "cip_launch_vehicle.json"))
    start = bench2.view().parameters()
    bench2.step()
    assert bench2.view().parameters() != start
    bench2.undo()
    assert bench2.view().parameters() == start and bench2.iteration == 0


def test_a_time_response_is_edited_as_one_line(workdir):
    """The wind profile of the launch vehicle's peak angle of attack, read and rewritten."""
    from tui.state.field_edits import target_edit

    bench = Workbench(load_session(workdir / "coebra_launch_vehicle.json"))
    edit = target_edit(bench, ("targets", 5), "response")
    assert edit.text == "alpha_w alpha 10 201; ramp 0 0.05; ramp 2 -0.05; reference 0"
    assert "HORIZON" in edit.check("alpha_w")
    assert "step T A; ramp T S; psd F(s); reference R" in edit.check("alpha_w alpha 10; gust 1 2")
    edit.apply("alpha_w alpha 12 241; ramp 0 0.1; ramp 1 -0.1; reference 0")
    response = bench.session.problem.targets[5].response
    assert (response.horizon, response.points, response.profile) == (12.0, 241, ((0.0, 0.0, 0.1), (1.0, 0.0, -0.1)))


def test_junction_signs_and_the_break_point_are_edited(workdir):
    from tui.state.edits import plant_edit
    from tui.state.plant_rows import plant_rows

    bench = Workbench(load_session(workdir / "report003_lag_lead.json"))
    refs = [ref for _, ref in plant_rows(bench.session.model.problem)]
    junction = plant_edit(bench, refs[2])  # rows: compensator, plant, the junction, the break point
    assert junction.text == "+r -y" and "write +SIGNAL" in junction.check("r y")
    junction.apply("+r +y")  # positive feedback: the problem changes, still builds
    assert bench.session.model.problem.conditions[0].plant.junctions[0].plus == ["r", "y"]
    junction.apply("+r -y")
    brk = plant_edit(bench, refs[3])
    assert brk.text == "e"
    brk.apply("u")
    assert bench.session.problem.conditions[0].break_at == "u"
    try:
        brk.apply("nowhere")
    except Exception as exc:  # an unknown signal is refused and the old value kept
        assert "nowhere" in str(exc)
    assert bench.session.model.problem.conditions[0].break_at == "u"


def test_conditions_are_copied_and_deleted_with_their_per_condition_values(workdir):
    from tui.state.edits import copy_condition, delete_condition
    from tui.state.field_edits import parameter_edit

    bench = Workbench(load_session(workdir / "coebra_launch_vehicle.json"))
    copy_condition(bench, ("conditions", 1, "break_at"), "max-q hot")  # a row of the max-q condition
    problem = bench.session.problem
    assert [c.name for c in problem.conditions][-1] == "max-q hot"
    kd = next(p for p in problem.parameters if p.name == "KD")
    assert len(kd.value) == 4 and kd.value[3] == kd.value[1]
    edit = parameter_edit(bench, ("parameters", 0), "value")  # KD: one per condition
    assert "one per condition" in edit.check("1, 2")
    edit.apply("0.5, 0.6, 0.7, 0.8")
    assert bench.session.problem.parameters[0].value == (0.5, 0.6, 0.7, 0.8)
    assert delete_condition(bench, ("conditions", 3, "plant", "blocks", 0)) == "max-q hot"
    assert len(bench.session.problem.conditions) == 3 and bench.session.problem.parameters[0].value == (0.5, 0.6, 0.7)


def test_shared_and_per_condition_toggle(workdir):
    from tui.state.field_edits import toggle_per_condition

    bench = Workbench(load_session(workdir / "coebra_launch_vehicle.json"))
    names = [p.name for p in bench.session.model.problem.parameters]
    toggle_per_condition(bench, ("parameters", names.index("TA")))
    assert bench.session.problem.parameters[names.index("TA")].value == (0.05, 0.05, 0.05)
    assert len(bench.session.problem.free_slots()) == 16
    toggle_per_condition(bench, ("parameters", names.index("TA")))
    assert bench.session.problem.parameters[names.index("TA")].value == 0.05


def test_matrix_entries_are_deleted_and_added(workdir):
    """Report 003's matrix format: e + y = theta, u = C e, y = G u."""
    import json

    doc = json.loads((workdir / "report003_lag_lead.json").read_text())
    doc["problem"]["conditions"][0]["plant"] = {
        "format": "matrix",
        "signals": ["e", "u", "y"],
        "forcing_row": 1,
        "forcing": "1",
        "input_name": "r",
        "entries": [
            {"row": 1, "col": 1, "expression": "1"},
            {"row": 1, "col": 3, "expression": "1"},
            {"row": 2, "col": 2, "expression": "1"},
            {"row": 2, "col": 1, "expression": "-(s+z1)*(s+z2)/((s+p1)*(s+p2))"},
            {"row": 3, "col": 3, "expression": "1"},
            {"row": 3, "col": 2, "expression": "-16000/(s*(s+8)*(s+20))"},
        ],
    }
    path = workdir / "matrix.json"
    path.write_text(json.dumps(doc))
    bench = Workbench(load_session(path))
    before = bench.view().loop_curve().gh
    from tui.state.edits import add_to_plant, delete_item
    from tui.state.plant_rows import plant_rows

    refs = [ref for _, ref in plant_rows(bench.session.model.problem)]
    assert delete_item(bench, refs[5]) == "matrix entry a[3,2]"
    add_to_plant(bench, refs[0], "3 2 -16000/(s*(s+8)*(s+20))")
    assert np.allclose(bench.view().loop_curve().gh, before, rtol=1e-12)


def test_plots_show_every_condition_at_its_own_parameters_then_each_alone(workdir):
    """Per-condition gains (KD, KR, KL differ by flight condition after a step) must
    reach each condition's curve; `v` cycles all -> each alone -> all."""
    from engine.loop.responses import open_loop

    bench = Workbench(load_session(workdir / "coebra_launch_vehicle.json"))
    bench.step()
    problem, record = bench.session.problem, bench.records[-1]
    names = [c.name for c in problem.conditions]
    curves = bench.view().loop_curves()
    assert [c.label for c in curves] == names and len({(c.role, c.index) for c in curves}) == len(names)
    for k, (curve, condition) in enumerate(zip(curves, problem.conditions)):
        values = problem.condition_values(k)
        values.update({n: v[k] if isinstance(v, list) else v for n, v in record.parameters.items()})
        expected = open_loop(
            condition.network, condition.break_at, problem.grid.omega, values, sensitivities=False
        ).value
        np.testing.assert_allclose(curve.gh, expected, rtol=1e-12)
    assert not np.allclose(curves[0].gh, curves[1].gh)
    messages = [bench.next_plotted_condition() for _ in names] + [bench.next_plotted_condition()]
    assert messages[0] == f"plots: {names[0]} (current and initial)" and messages[-1] == "plots: every flight condition"
    bench.plotted_condition = 1
    alone = bench.view().loop_curves()
    assert [c.label for c in alone] == [f"{names[1]}: current", f"{names[1]}: initial"]
    np.testing.assert_allclose(alone[0].gh, curves[1].gh, rtol=1e-12)
    name, traces, _ = bench.view().step_plot()
    assert [t[2] for t in traces] == [f"{names[1]}: current", f"{names[1]}: initial"]


def test_bode_plots_mark_the_margins_of_report_003(workdir):
    """Report 003 chapter 1, lag-lead compensated: PM 52.13 deg at 12.06 rad/s, GM 14.11 dB."""
    from tui.figures.open_loop import bode_figures

    bench = Workbench(load_session(workdir / "report003_lag_lead.json"))
    magnitude, phase = bode_figures(bench.view().loop_curves(), "rad/s")
    marks = {s.label: s for s in magnitude.series if s.scatter}
    assert set(marks) == {"PM 52.1 deg", "GM 14.1 dB"}
    pm, gm = marks["PM 52.1 deg"], marks["GM 14.1 dB"]
    assert pm.y == [0.0] and abs(10 ** pm.x[0] - 12.06) < 0.005
    assert abs(gm.y[0] + 14.11) < 0.005
    phase_marks = {s.label: s for s in phase.series if s.scatter}
    assert abs(phase_marks["PM 52.1 deg"].y[0] % 360 - (52.13 + 180) % 360) < 0.5
    assert abs(phase_marks["GM 14.1 dB"].y[0] % 360 - 180) < 0.5


def test_the_convergence_starts_at_iteration_0_and_names_are_whole(workdir):
    from tui.state.tableau_text import tableau_text

    bench = Workbench(load_session(workdir / "seidel_inlet_pi.json"))
    bench.step()
    label, iterations, values = bench.view().convergence()
    assert iterations[:2] == [0, 1] and len(values) == 2
    rows, _ = bench.view().tableau()
    text = tableau_text(rows, [], "hz").plain
    assert "x1_normalized" in text and "x1_rate_normalized" in text


def test_a_run_keeps_the_json_its_worker_made(workdir):
    """A run's worker converts each record and state (`stored_json`) so the UI
    thread does not; the session keeps exactly what `commit` would have made."""
    import json

    from tui.state.bench.records import stored_json

    own, given = (Workbench(load_session(workdir / "cip_launch_vehicle.json")) for _ in range(2))
    for _ in range(3):
        algorithm, state = given.begin_run()
        state, record = algorithm.step(state)
        given.commit(state, record, stored_json(state, record, given.settings))
        own.step()
    assert json.dumps(given.session.model.records) == json.dumps(own.session.model.records)
    assert json.dumps(given.session.model.state) == json.dumps(own.session.model.state)
    assert given.iteration == own.iteration == 3


def test_a_parameter_edit_keeps_the_loops_built_and_reads_as_the_saved_session_does(workdir):
    """A drag's or a nudge's edit changes parameter values alone: the conditions' loops (the
    launch vehicle's tables read, the plant's forms kept on them) are kept, not built again
    (before, every edit built them from the model); the tableau is the one a fresh load of
    the saved session reads.  An edit of the plant builds them anew."""
    from sessions.store import save_session
    from tui.state import edits

    bench = Workbench(load_session(workdir / "cip_launch_vehicle.json"))
    built = bench.session.problem.conditions
    first = bench.session.problem.parameters[0]
    edits.set_parameters(bench, {first.name: float(np.ravel(first.value)[0]) * 1.1})
    assert all(a is b for a, b in zip(bench.session.problem.conditions, built, strict=True))
    path = save_session(bench.session, workdir / "edited.json")
    fresh = Workbench(load_session(path))
    assert bench.view().tableau()[0] == fresh.view().tableau()[0]
    edits.set_fields(bench, ("conditions", 0, "plant", "channels", 0), gain=2.0)
    assert not any(a is b for a, b in zip(bench.session.problem.conditions, built, strict=True))
