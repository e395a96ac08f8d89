"""A target the chosen algorithm cannot use is flagged where it is edited, and
choosing an algorithm says what it will refuse or ignore."""

from __future__ import annotations

from engine.design.measure_kinds import MEASURE_KINDS
from engine.stepping.registry import lookup
from sessions.target_use import target_note, unusable_targets, used_by
from tests.tui.test_app import settle, synchronous
from tui.app import LoopcraftApp
from tui.screens.dialogs import ChooseDialog


def test_every_measure_is_flagged_exactly_for_the_algorithms_that_refuse_it():
    for name in MEASURE_KINDS:
        for algorithm in ("cip", "slp"):
            note = target_note(name, algorithm)
            accepted = lookup(algorithm).targets.accepts(name)
            assert (note == "") == accepted, (name, algorithm, note)
            assert bool(unusable_targets([name], algorithm)) == (not accepted)
        assert target_note(name, "qcg") == "ignored by qcg"
    assert unusable_targets([], "qcg") == [] and target_note("gain_margin", "newton") == ""  # not installed


@synchronous
async def test_a_crossover_target_is_marked_for_cip_and_listed_when_cip_is_chosen(workdir):
    app = LoopcraftApp(workdir / "coebra_lag_lead.json")
    async with app.run_test(size=(120, 40)) as pilot:
        await settle(app, pilot)
        assert app.bench.algorithm_name == "slp"
        measures = [t.measure for t in app.bench.session.model.problem.targets]
        assert "crossover_frequency" in measures
        await pilot.press("3")  # the Targets tab: a hidden tab is drawn when it is shown
        await settle(app, pilot)
        table = app.screen.query_one("#targets-table")
        row = measures.index("crossover_frequency")
        assert str(table.get_row_at(row)[1]) == "yes"
        await pilot.press("a")
        await pilot.pause()
        dialog = app.screen
        assert isinstance(dialog, ChooseDialog)
        assert dict(dialog.choices)["cip"].endswith("[1 of the targets judged only]")
        assert "judged only" not in dict(dialog.choices)["slp"]
        dialog.dismiss("cip")
        await settle(app, pilot)
        assert app.bench.algorithm_name == "cip"
        assert str(table.get_row_at(row)[1]) == f"not cip ({used_by('crossover_frequency')})"  # slp, and plug-ins
        assert any("crossover_frequency: judged only: cip does not read it" in n.message for n in app._notifications)
        rows = app.bench.initial_record().measures  # cip runs on the margins, the crossover judged beside them
        assert [r.method for r in rows if r.kind == "crossover_frequency"] == ["judged only: cip does not read it"]
