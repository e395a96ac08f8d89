"""Parts added to a compensator and items deleted (issue 38, section 1): each part's
roots where its title places them (closed forms about w), and deleting every item it
added gives back the expression and the parameters it started with."""

from __future__ import annotations

import pytest

from engine.design.compensator_items import items
from engine.model.blocks import ExpressionTransfer
from engine.model.factor_text import product
from sessions.compensator_parts import PARTS, add_part, remove_item

W = 2.0
EXPECTED = {  # (kind, frequency, damping or None) of the items each part adds, about W
    "lead": [("zero", W / 3, None), ("pole", 3 * W, None)],
    "lag": [("zero", W / 10, None), ("pole", W / 100, None)],
    "int": [("integrator", 0.0, None), ("zero", W / 10, None)],
    "zero": [("zero", W, None)],
    "pole": [("pole", 10 * W, None)],
    "notch": [("zero pair", W, 0.05), ("pole pair", W, 0.5)],
    "pair": [("pole pair", 10 * W, 0.5)],
}


@pytest.fixture
def lead(tmp_path, monkeypatch):
    """The problem of a new lead session for 1/(s^2 (s+10)): K*(1+T1*s)/(1+T2*s)."""
    from sessions.store import load_session
    from tui.cli import main

    monkeypatch.setenv("LOOPCRAFT_HOME", str(tmp_path / "home"))
    assert main(["new", str(tmp_path / "lead.json"), "--plant", "1/(s^2*(s+10))", "--compensator", "lead"]) == 0
    return lambda: load_session(tmp_path / "lead.json").model.problem.model_copy(deep=True)


@pytest.mark.parametrize("kind", sorted(PARTS))
def test_a_part_adds_its_roots_where_its_title_says_and_deleting_them_gives_the_start_back(kind, lead):
    draft = lead()
    start = (draft.conditions[0].plant.blocks[0].transfer.expression, [p.name for p in draft.parameters])
    names = add_part(draft, "compensator", kind, W)
    text = draft.conditions[0].plant.blocks[0].transfer.expression
    values = {p.name: p.value for p in draft.parameters}
    before = items(ExpressionTransfer(start[0]), values)
    found = [
        i
        for i in items(ExpressionTransfer(text), values)
        if i.kind != "gain" and (i not in before or set(i.parameters) & set(names))
    ]
    got = sorted(
        (i.kind, abs(i.root), None if not i.kind.endswith("pair") else -i.root.real / abs(i.root)) for i in found
    )
    for (k, w, zeta), (gk, gw, gz) in zip(sorted(EXPECTED[kind]), got, strict=True):
        assert (gk, gw) == (k, pytest.approx(w, rel=1e-9)) and (zeta is None or gz == pytest.approx(zeta, rel=1e-9))
    for item in found:
        if any(n in names for n in item.parameters):
            values = {p.name: p.value for p in draft.parameters}
            remove_item(draft, "compensator", values, item.root, item.kind)
    assert product(draft.conditions[0].plant.blocks[0].transfer.expression) == product(start[0])
    assert [p.name for p in draft.parameters] == start[1]


def test_a_root_of_a_larger_polynomial_goes_with_its_factor_and_says_so(lead):
    draft = lead()
    draft.conditions[0].plant.blocks[0].transfer.expression = "K*(1+a*s+b*s^2)/(1+T2*s)"
    draft.parameters[1].name = "a"
    draft.parameters.append(draft.parameters[1].model_copy(update={"name": "b"}))
    draft.constraints.clear()
    values = {"K": 1.0, "a": 3.0, "b": 2.0, "T2": 0.1}  # zeros at -1 and -0.5
    lines = remove_item(draft, "compensator", values, complex(-1.0), "zero")
    assert lines[0] == "compensator: the factor 1+a*s+b*s^2 goes, with its other roots -0.5+0j -> K/(1+T2*s)"
    assert lines[1:] == ["parameter a goes", "parameter b goes"]


def test_factors_keep_their_text():
    p = product("K*(1+T1*s)/((1+T2*s)*(1+T3*s))")
    assert p.numerator == ("K", "1+T1*s") and p.denominator == ("1+T2*s", "1+T3*s")
    assert p.without(under=0).text == "K*(1+T1*s)/(1+T3*s)" and product("a/b/c*d").text == "a*d/(b*c)"
    assert product("-1600/(s^2+56*s+1600)").without(under=0).text == "(-1600)"


def test_an_integrator_goes_with_the_factor_that_holds_it_over_or_under_the_line(lead):
    draft = lead()
    add_part(draft, "compensator", "int", W)
    values = {p.name: p.value for p in draft.parameters}
    lines = remove_item(draft, "compensator", values, 0j, "integrator")
    assert lines[0] == "compensator: the factor 1+int1_wi/s goes, with its other roots -0.2+0j -> K*(1+T1*s)/(1+T2*s)"


def test_a_deleted_parameter_takes_its_equalities_and_one_named_elsewhere_stays(lead):
    from sessions.format.schema import EqualityModel

    draft = lead()
    draft.equalities.append(EqualityModel(terms={"T1": 1.0, "T2": -10.0}, value=0.0))
    values = {p.name: p.value for p in draft.parameters}
    lines = remove_item(draft, "compensator", values, complex(-1 / values["T1"]), "zero")
    assert "parameter T1 goes" in lines and any(line.startswith("equality 1*T1 + -10*T2 = 0 goes") for line in lines)
    assert draft.equalities == [] and "T1" not in {p.name for p in draft.parameters}
    draft = lead()
    draft.conditions[0].plant.blocks[1].transfer.expression = "T1/(s^2*(s+10))"  # the plant names T1 too
    values = {p.name: p.value for p in draft.parameters}
    lines = remove_item(draft, "compensator", values, complex(-1 / values["T1"]), "zero")
    assert "parameter T1 goes" not in lines and "T1" in {p.name for p in draft.parameters}
