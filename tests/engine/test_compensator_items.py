"""A compensator as the engineer reads it (issue 38, section 1): gain, corners, pairs and
the parameters behind each, against closed forms and numpy's polynomial roots."""

from __future__ import annotations

import math

import numpy as np
import pytest

from engine.design.compensator_items import Item, items
from engine.model.blocks import ExpressionTransfer


def _by_kind(found):
    return [(i.kind, i.root, i.parameters) for i in found]


def test_a_lead_reads_as_gain_zero_and_pole_each_with_its_parameter():
    found = items(ExpressionTransfer("K*(1+T1*s)/(1+T2*s)"), {"K": 7.0, "T1": 1.5, "T2": 0.1})
    (gain, g, by_gain), (zero, z, by_zero), (pole, p, by_pole) = _by_kind(found)
    assert (gain, zero, pole) == ("gain", "zero", "pole")
    assert g.real == pytest.approx(7.0) and z == pytest.approx(-1 / 1.5) and p == pytest.approx(-10.0)
    assert (by_gain, by_zero, by_pole) == (("K",), ("T1",), ("T2",))
    assert found[1].text == "zero at 0.666667 rad/s (T 1.5 s) [T1]"


def test_pairs_integrators_and_the_right_half_plane():
    found = items(ExpressionTransfer("K*(s^2+2*zn*wn*s+wn^2)/(s*(s+a))"), {"K": 2.0, "zn": 0.3, "wn": 2.0, "a": 10.0})
    kinds = [i.kind for i in found]
    assert kinds == ["gain", "integrator", "zero pair", "pole"]
    pair = found[2]
    assert abs(pair.root) == pytest.approx(2.0) and -pair.root.real / abs(pair.root) == pytest.approx(0.3)
    assert set(pair.parameters) == {"wn", "zn"} and found[0].root.real == pytest.approx(2.0 * 4.0 / 10.0)
    rhp = items(ExpressionTransfer("(1-T*s)/(1+T*s)"), {"T": 0.5})
    assert "right half-plane" in rhp[1].text and rhp[1].root == pytest.approx(2.0)


def test_a_polynomial_compensator_shows_its_roots_moved_by_its_coefficients():
    values = {"x0": 1.0, "x1": 0.5, "x2": 0.1, "y1": 0.3, "y2": 0.02}
    found = items(ExpressionTransfer("(x0+x1*s+x2*s^2)/(1+y1*s+y2*s^2)"), values)
    zeros = np.roots([0.1, 0.5, 1.0])
    poles = np.roots([0.02, 0.3, 1.0])
    pair = next(i for i in found if i.kind == "zero pair")
    assert pair.root == pytest.approx(zeros[zeros.imag > 0][0]) and set(pair.parameters) == {"x0", "x1", "x2"}
    real = sorted(abs(i.root) for i in found if i.kind == "pole")
    assert real == pytest.approx(sorted(abs(poles))) and found[0].root.real == pytest.approx(1.0)
    assert [abs(i.root) for i in found[1:]] == sorted(abs(i.root) for i in found[1:])  # low frequency first
    assert math.isclose(abs(pair.root), math.sqrt(10.0))


def test_moving_an_item_solves_for_the_parameter_that_owns_it():
    from engine.design.compensator_moves import moved

    lead = ExpressionTransfer("K*(1+T1*s)/(1+T2*s)")
    values = {"K": 7.0, "T1": 1.5, "T2": 0.1}
    assert moved(lead, values, 1, 0.7) == {"T1": pytest.approx(1 / 0.7, rel=1e-10)}  # the zero to 0.7 rad/s
    assert moved(lead, values, 2, 12.0) == {"T2": pytest.approx(1 / 12.0, rel=1e-10)}
    assert moved(lead, values, 0, 14.0) == {"K": pytest.approx(14.0, rel=1e-10)}
    notch = ExpressionTransfer("K*(s^2+2*zn*wn*s+wn^2)/(s*(s+a))")
    values = {"K": 2.0, "zn": 0.3, "wn": 2.0, "a": 10.0}
    # wn moves the pair and the Bode gain K wn^2/a: K keeps the gain (2 * 4/10), zeta kept
    assert moved(notch, values, 2, 2.5) == {"wn": pytest.approx(2.5, rel=1e-10), "K": pytest.approx(1.28, rel=1e-10)}
    assert moved(notch, values, 2, 0.5, "damping") == {"zn": pytest.approx(0.5, rel=1e-10)}


def test_a_root_of_a_polynomial_moves_by_its_coefficients_together_keeping_the_gain_and_the_other_roots():
    from engine.design.compensator_moves import moved

    # (x0 + x1 s + x2 s^2)/(y0 + y1 s + y2 s^2), as cip writes a compensator; y0 held (hold_dc_gain)
    cip = ExpressionTransfer("(x0+x1*s+x2*s^2)/(y0+y1*s+y2*s^2)")
    values = {"x0": 1.0, "x1": 0.5, "x2": 0.1, "y0": 1.0, "y1": 0.3, "y2": 0.02}
    poles = sorted(abs(np.roots([0.02, 0.3, 1.0])))  # 5 and 10 rad/s
    found = items(cip, values)
    index = next(k for k, i in enumerate(found) if i.kind == "pole" and abs(abs(i.root) - poles[0]) < 1e-9)
    solved = moved(cip, values, index, 6.0, bounds={"y0": (1.0, 1.0)})
    # closed form: y0 (1 + s/6)(1 + s/10) = 1 + (1/6 + 1/10) s + s^2/60
    assert solved == {"y1": pytest.approx(1 / 6 + 1 / 10, rel=1e-9), "y2": pytest.approx(1 / 60, rel=1e-9)}
    pair = next(k for k, i in enumerate(found) if i.kind == "zero pair")
    zeta = 0.5 / (2 * math.sqrt(0.1))  # x1 / (2 sqrt(x0 x2))
    solved = moved(cip, values, pair, 2.0)  # wn to 2 rad/s, zeta and the DC gain x0 kept: x2 = x0/wn^2
    assert solved == {"x1": pytest.approx(2 * zeta * 2.0 * 0.25, rel=1e-9), "x2": pytest.approx(0.25, rel=1e-9)}
    assert moved(cip, values, pair, 0.5, "damping") == {"x1": pytest.approx(2 * 0.5 * math.sqrt(0.1), rel=1e-9)}


def test_moving_an_item_no_parameter_can_move_is_refused_with_the_reason():
    from engine.design.compensator_moves import moved
    from engine.errors import EngineError

    values = {"x0": 1.0, "x1": 0.5, "x2": 0.1, "y1": 0.3, "y2": 0.02}
    with pytest.raises(EngineError, match="no values of y1, y2.* within their bounds"):
        moved(ExpressionTransfer("(x0+x1*s+x2*s^2)/(1+y1*s+y2*s^2)"), values, 2, 6.0, bounds={"y2": (0.019, 0.021)})
    corners = {"z1": 1.0, "z2": 5.0, "p1": 0.1, "p2": 50.0}
    with pytest.raises(EngineError, match="write the compensator as K"):
        moved(ExpressionTransfer("(s+z1)*(s+z2)/((s+p1)*(s+p2))"), corners, 0, 2.0)
    with pytest.raises(EngineError, match="within its bounds"):
        moved(
            ExpressionTransfer("K*(1+T1*s)/(1+T2*s)"),
            {"K": 1.0, "T1": 1.0, "T2": 0.1},
            1,
            0.01,
            bounds={"T1": (0.5, 2)},
        )


def test_a_negative_gain_is_moved_by_its_size_and_keeps_its_sign():
    from engine.analysis import unity_feedback
    from engine.design.compensator_moves import move_named

    network = unity_feedback(["K*(1+T1*s)/(1+T2*s)", "1/(s+1)"], "s", 0.0)
    label = next(e.label for e in network.entries if "K" in e.transfer.parameters)
    move = move_named(network, {"K": -3.0, "T1": 1.0, "T2": 0.1}, f"{label}.gain", lambda now: 2 * now)
    assert (move.now, move.target) == (3.0, 6.0) and move.values == {"K": pytest.approx(-6.0)}


def test_a_right_half_plane_pair_moves_with_its_damping_s_sign_kept():
    """x0 + x1 s + x2 s^2 with x1 < 0: zeros at wn 2, zeta -0.6.  Moving wn to 3 keeps
    zeta -0.6 and the DC gain x0: x2 = x0/9, x1 = 2 zeta wn x2 = -0.4 (closed form)."""
    from engine.design.compensator_moves import moved

    transfer = ExpressionTransfer("(x0+x1*s+x2*s^2)/(1+y1*s)")
    values = {"x0": 1.0, "x1": -0.6, "x2": 0.25, "y1": 0.1}
    pair = next(k for k, i in enumerate(items(transfer, values)) if i.kind == "zero pair")
    assert moved(transfer, values, pair, 3.0) == {
        "x1": pytest.approx(-0.4, rel=1e-9),
        "x2": pytest.approx(1 / 9, rel=1e-9),
    }


@pytest.mark.parametrize("gain", [1.0 - 2.0**-52, 1.0, 1.0 + 2.0**-52])
def test_a_unit_gain_reads_0_db_never_minus_0(gain):
    """A gain of 1 to rounding (the Bode gain of a product whose factors cancel) reads '(0 dB)':
    cip_dual_channel's unit gains printed '-0 dB' or '0 dB' by their last bit."""
    assert "(0 dB)" in Item("gain", complex(gain), ()).text


def test_a_zero_moved_past_another_of_its_kind_stays_itself_and_says_its_new_name():
    """Items are numbered by frequency: zero1 at 1 rad/s moved to 3 rad/s, past zero2 at 2,
    is the zero T1 owns at 3 rad/s, now named zero2, the other zero left at 2 (the
    numerator's roots by numpy).  Before, the solve followed whichever zero was nearest the
    start and found no T1 at all."""
    from engine.analysis import unity_feedback
    from engine.design.compensator_moves import move_named

    network = unity_feedback(["K*(1+T1*s)*(1+T2*s)/((1+T3*s)*(1+T4*s))", "1/(s^2*(s+10))"], "s", 0.0)
    label = next(e.label for e in network.entries if "K" in e.transfer.parameters)
    values = {"K": 2.0, "T1": 1.0, "T2": 0.5, "T3": 0.05, "T4": 0.02}
    move = move_named(network, values, f"{label}.zero1", lambda now: 3.0)
    assert move.values == {"T1": pytest.approx(1 / 3, rel=1e-12)} and move.name == f"{label}.zero2"
    after = {**values, **move.values}
    zeros = np.roots(np.polymul([after["T1"], 1.0], [after["T2"], 1.0]))
    assert sorted(abs(zeros)) == pytest.approx([2.0, 3.0], rel=1e-12)
    back = move_named(network, after, move.name, lambda now: 1.5)  # by its new name, back past the other
    assert back.values == {"T1": pytest.approx(1 / 1.5, rel=1e-12)} and back.name == f"{label}.zero1"


def test_items_kept_for_a_design_are_that_designs(monkeypatch):
    """`items` keeps the latest designs' items (a nudge reads them where the shaping table
    did): the same block at the same values is read once; other values, or another block of
    the same text, are read for themselves (the zero at 1/T1 as numpy finds it)."""
    from engine.analysis import unity_feedback
    from engine.design import compensator_items

    read, pole_zero = [], compensator_items.pole_zero
    monkeypatch.setattr(compensator_items, "pole_zero", lambda e, p: read.append(dict(p)) or pole_zero(e, p))

    def zero(found):
        return next(abs(i.root) for i in found if i.kind == "zero")

    network = unity_feedback(["K*(1+T1*s)/(1+T2*s)", "1/s^2"], "s", 0.0)
    block = next(e.transfer for e in network.entries if "K" in e.transfer.parameters)
    twin = ExpressionTransfer(block.text)
    values = {"K": 2.0, "T1": 1.0, "T2": 0.1}
    first = items(block, values)
    assert len(read) == 1  # the block's form alone: its owners are exact derivatives (before: 4, one per nudge)
    assert items(block, values) == first and items(block, values) is not first  # a list of one's own
    assert len(read) == 1
    moved = items(block, {**values, "T1": 0.5})
    assert zero(moved) == pytest.approx(abs(np.roots([0.5, 1.0])[0]), rel=1e-12)
    assert zero(items(block, values)) == pytest.approx(1.0, rel=1e-12)
    assert items(twin, values) == first and zero(items(twin, {**values, "T1": 0.25})) == pytest.approx(4.0)


def test_a_missing_parameter_is_named_not_a_bare_key_error():
    """Before, `items` and `item_slopes` raised KeyError('T2'), which no caller turns into a message."""
    from engine.design.compensator_items import item_slopes
    from engine.errors import ParameterError

    block = ExpressionTransfer("K*(1+T1*s)/(1+T2*s)")
    for read in (lambda: items(block, {"K": 2.0, "T1": 1.0}), lambda: item_slopes(block, {"K": 2.0}, [])):
        with pytest.raises(ParameterError, match="no value for parameter.*T2.*K\\*\\(1\\+T1\\*s\\)"):
            read()


def test_a_root_that_moves_little_is_still_its_parameters():
    """A cubic numerator's zeros at 0.001, 1 and 10 rad/s: each zero is a root of
    x1 s^3 + x2 s^2 + x3 s + x4, so every coefficient moves it (dr/dx = -r^k / p'(r), not 0),
    though x1 moves the lowest by 1e-7 and x4 the highest by 1e-5 of a relative change (a nudge
    of 1e-6 read them as fixed: the low zero could not be moved).  The move is checked by
    numpy's roots of the solved coefficients."""
    from engine.design.compensator_moves import moved

    roots = [-1e-3, -1.0, -10.0]
    coefficients = dict(zip(["x1", "x2", "x3", "x4"], (float(c) for c in np.poly(roots))))
    block = ExpressionTransfer("(x1*s^3 + x2*s^2 + x3*s + x4)/((s+100)*(s+200)*(s+300))")
    found = items(block, coefficients)
    zeros = [i for i in found if i.kind == "zero"]
    assert [abs(i.root) for i in zeros] == pytest.approx([1e-3, 1.0, 10.0], rel=1e-9)
    assert [i.parameters for i in zeros] == [("x1", "x2", "x3", "x4")] * 3
    assert found[0].parameters == ("x4",)  # the Bode gain x4 / 6e6 alone
    solved = {**coefficients, **moved(block, coefficients, 1, 2e-3)}
    after = np.sort(np.abs(np.roots([solved[n] for n in ("x1", "x2", "x3", "x4")])))
    assert after == pytest.approx([2e-3, 1.0, 10.0], rel=1e-9) and solved["x4"] == coefficients["x4"]


@pytest.mark.parametrize("seed", range(4))
def test_every_root_of_a_typed_polynomial_is_every_coefficients(seed):
    """Roots spread over five decades (seeded): a simple root r of sum x_k s^k moves with every
    coefficient (dr/dx_k = -r^k / p'(r), never 0 away from the origin), and the Bode gain
    x0 / y0 with the constant terms alone."""
    rng = np.random.default_rng(seed)
    zeros, poles = (-(10.0 ** rng.uniform(-3, 2, size=3)) for _ in range(2))
    names = {"x": ("x0", "x1", "x2", "x3"), "y": ("y0", "y1", "y2", "y3")}
    values = {}
    for side, roots in (("x", zeros), ("y", poles)):
        values.update(zip(names[side], (float(c) for c in np.poly(roots)[::-1])))
    text = "(x0 + x1*s + x2*s^2 + x3*s^3)/(y0 + y1*s + y2*s^2 + y3*s^3)"
    found = items(ExpressionTransfer(text), values)
    assert found[0].parameters == ("x0", "y0")
    for item in found[1:]:
        side = "x" if item.kind == "zero" else "y"
        assert item.parameters == names[side], item.text


def test_the_derivatives_are_the_closed_forms_and_a_repeated_root_is_nudged():
    """d root / d log x against closed forms (the zero -1/T1 of K (1 + T1 s): 1/T1; the Bode
    gain K a / b of K (s + a) / (s + b): d log / d log of each 1, -1); a double zero has no
    derivative (p'(r) = 0): its parameters are found by the nudge, as before."""
    from engine.design.compensator_items import item_slopes

    lead = ExpressionTransfer("K*(1+T1*s)/(1+T2*s)")
    values = {"K": 7.0, "T1": 1.5, "T2": 0.1}
    found = items(lead, values)
    slopes = item_slopes(lead, values, found)
    assert slopes["T1"][1] == pytest.approx(1 / 1.5, rel=1e-12) and abs(slopes["T1"][2]) == 0
    assert slopes["T2"][2] == pytest.approx(1 / 0.1, rel=1e-12) and slopes["K"][0] == pytest.approx(1.0, rel=1e-12)
    corner = ExpressionTransfer("K*(s+a)/(s+b)")
    values = {"K": 2.0, "a": 1.0, "b": 10.0}
    slopes = item_slopes(corner, values, items(corner, values))
    assert [slopes[n][0].real for n in ("K", "a", "b")] == pytest.approx([1.0, 1.0, -1.0], rel=1e-12)
    double = ExpressionTransfer("K*(s+a)^2/(s+b)")
    values = {"K": 2.0, "a": 1.0, "b": 10.0}
    assert item_slopes(double, values, items(double, values)) == {}
    assert [i.parameters for i in items(double, values)] == [("K", "a", "b"), ("a",), ("a",), ("b",)]


def test_a_parameter_that_moves_a_pole_by_a_thousandth_owns_it():
    """K (s + a)/(s + a + e), e = 1e-3: the pole -(a + e) moves with e, and the Bode gain
    K a/(a + e) with a and e (d log / d log = 1e-3 each in closed form, 1e-9 under a nudge of
    1e-6: the nudge's threshold, not above it, left them out: the gain [K], the pole [a] on
    cdde28a)."""
    found = items(ExpressionTransfer("K*(s+a)/(s+a+e)"), {"K": 1.0, "a": 1.0, "e": 1e-3})
    assert [i.parameters for i in found] == [("K", "a", "e"), ("a",), ("a", "e")]
