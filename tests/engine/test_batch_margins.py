"""The margins of many loops of one structure at once (issue 41, section 1): the batch
path (`engine.loop.batch_forms`, `engine.margins.batch`) against the per-loop path
(`engine.margins.search.margins` on the loop's model) on random rational loops, every
gain and phase margin equal to 1e-12 relative; samples whose batch certificate fails
(near-tangent crossovers) found by the per-loop search instead, as equal; delay and
tabulated loops have no batch form."""

from __future__ import annotations

import numpy as np
import pytest

from engine.analysis import unity_feedback
from engine.loop.batch_forms import batch_pole_zero
from engine.loop.design import closed_loop_realization
from engine.loop.responses import loop_model
from engine.margins.batch import batch_margins
from engine.margins.pole_zero.batch_search import leave_one_out
from engine.margins.search import margins
from engine.model.blocks import FrequencyTable
from engine.model.network import Network
from tests.engine.loopfactory import random_cascade_structure

OMEGA = np.logspace(-3, 3, 200)
EXACT = 1e-12


def _samples(values: dict[str, float], count: int, spread: float, rng: np.random.Generator) -> dict[str, np.ndarray]:
    return {name: value * (1 + rng.uniform(-spread, spread, count)) for name, value in values.items()}


def _same(batch: list, loop: list, kind: str) -> None:
    assert [m.frequency for m in batch] == pytest.approx([m.frequency for m in loop], rel=EXACT), kind
    for attribute in ("value", "gain_db", "phase_deg"):
        got = [getattr(m, attribute) for m in batch]
        want = [getattr(m, attribute) for m in loop]
        assert got == pytest.approx(want, rel=EXACT, abs=1e-300), (kind, attribute)


def _check_against_per_loop(network: Network, columns: dict[str, np.ndarray]) -> list:
    """Every sample's batch margins equal the per-loop path's; the samples' loops."""
    forms = batch_pole_zero(network, "e", columns)
    assert forms is not None
    found = batch_margins(forms)
    for k, sample in enumerate(found):
        params = {name: float(values[k]) for name, values in columns.items()}
        if sample is None:
            continue
        per_loop = margins(loop_model(network, "e", OMEGA, params))
        _same(sample.margins.gain, per_loop.gain, "gain")
        _same(sample.margins.phase, per_loop.phase, "phase")
        poles = np.linalg.eigvals(closed_loop_realization(network, "e", params).A)
        assert sample.abscissa == pytest.approx(-np.max(poles.real), rel=1e-9, abs=1e-9 * np.abs(poles).max())
    return found


@pytest.mark.long
def test_random_loops_equal_the_per_loop_path():
    """12 random structures of 40 samples each; most samples certified by the batch (the rest,
    crossings near a light resonance whose rounding moves GH by more than 1e-13, go to the
    per-loop search)."""
    batched = 0
    for seed in range(12):
        rng = np.random.default_rng(seed)
        blocks, values = random_cascade_structure(rng)
        found = _check_against_per_loop(unity_feedback(blocks), _samples(values, 40, 0.2, rng))
        batched += sum(sample is not None and sample.batched for sample in found)
    assert batched >= 0.7 * 12 * 40


def test_near_tangent_crossovers_fall_back_and_still_agree():
    """|GH| peaks at 1 within rounding at a resonance: two crossovers nearly meet, which the
    batch's certificate does not settle; those samples are found by the per-loop search (or
    the per-loop path), as equal."""
    network = unity_feedback(["k*25/(s**2 + 0.1*s + 25)/(s/1000 + 1)"])
    peak = max(
        abs(m.gh) for m in margins(loop_model(network, "e", OMEGA, {"k": 1.0}), attenuation_above=0.0).attenuation
    )
    k = (1 + np.concatenate([np.linspace(-1e-8, 1e-8, 9), np.linspace(-1e-14, 1e-14, 9)])) / peak
    found = _check_against_per_loop(network, {"k": k})
    assert any(sample is None or not sample.batched for sample in found)


def test_odd_samples_are_left_to_the_per_loop_path():
    """A sample whose zero cancels a pole (the per-loop path cancels it) has no batch form."""
    network = unity_feedback(["k*(s/a + 1)/((s/b + 1)*s)"])
    forms = batch_pole_zero(
        network, "e", {"k": np.array([2.0, 2.0]), "a": np.array([3.0, 5.0]), "b": np.array([5.0, 5.0])}
    )
    assert forms.odd.tolist() == [False, True]
    assert batch_margins(forms)[1] is None


@pytest.mark.parametrize(
    "network",
    [
        unity_feedback(["k/(s*(s + 1))"], delay=0.1),
        unity_feedback(["k"], table=FrequencyTable(np.logspace(-1, 2, 40), 1 / (1j * np.logspace(-1, 2, 40) + 1))),
    ],
    ids=["delay", "table"],
)
def test_delay_and_tabulated_loops_have_no_batch_form(network):
    assert batch_pole_zero(network, "e", {"k": np.array([1.0, 2.0])}) is None


def test_a_negative_dc_gain_is_a_gain_margin_at_zero():
    """GH(0) on the negative real axis (no integrator): the gain margin at 0 rad/s, listed first."""
    rng = np.random.default_rng(5)
    network = unity_feedback(["-k/((s/a + 1)*(s**2/b**2 + 0.2*s/b + 1))"])
    found = _check_against_per_loop(network, _samples({"k": 0.5, "a": 2.0, "b": 10.0}, 20, 0.3, rng))
    assert all(sample.margins.gain[0].frequency == 0.0 for sample in found if sample is not None)
    assert sum(sample is not None and sample.batched for sample in found) >= 15


def test_sums_of_light_close_modes_go_to_the_per_loop_path_where_their_zeros_are_off():
    """A block typed as a sum of lightly damped, closely spaced modes (issue 35, section 5): the
    roots of its expanded numerator are off by up to 1e-2, which the per-loop path polishes; the
    batch measures their backward error and leaves such samples to it, so every sample's margins
    still equal the per-loop path's."""
    from tests.engine.test_sum_of_modes import _modes

    text, _ = _modes(3)
    network = unity_feedback([f"k*({text})"])
    rng = np.random.default_rng(41)
    found = _check_against_per_loop(network, {"k": 10 ** rng.uniform(-1, 1, 12)})
    assert any(sample is None or not sample.batched for sample in found)


def _light_mode_plant(rng: np.random.Generator) -> tuple[list[str], dict[str, float]]:
    """A lead on a 7th-order plant: an integrator, three real poles, a lightly damped mode
    (zeta 0.005-0.05 at 20-80 rad/s) and a far pole; the nominal values."""
    poles = np.sort(10 ** rng.uniform(-0.5, 2.0, 3)).tolist()
    wn, zeta = float(10 ** rng.uniform(1.3, 1.9)), float(10 ** rng.uniform(-2.3, -1.3))
    plant = (
        "/(s*" + "*".join(f"(s/{p!r}+1)" for p in poles) + f")*{wn**2!r}/(s**2+{2 * zeta * wn!r}*s+{wn**2!r})/(s/300+1)"
    )
    values = {"k": float(10 ** rng.uniform(-0.5, 1.5)), "a": 0.5, "b": 0.05}
    return ["k*(1+a*s)/(1+b*s)", f"1{plant}"], values


def test_light_modes_are_batched_and_equal_the_per_loop_path():
    """Issue 53, section 1: a lightly damped mode in the plant; its crossings' rounding bound
    (worst case, 8 ulp a root) exceeded the 1e-13 the batch took, so every sample of some of
    these plants went to the per-loop search (73 of 320 batched, none of seeds 0-3, 5, 6);
    now 305, every one equal to the per-loop path."""
    batched = total = 0
    for seed in range(8):
        rng = np.random.default_rng(seed)
        blocks, values = _light_mode_plant(rng)
        found = _check_against_per_loop(unity_feedback(blocks), _samples(values, 40, 0.1, rng))
        batched += sum(sample is not None and sample.batched for sample in found)
        total += len(found)
    assert batched >= 0.9 * total  # 305 of 320 (73 before)


def test_phase_margins_within_rounding_go_to_the_per_loop_search():
    """A type-2 loop's crossover at 1e-11 rad/s: its phase margin, 1e-11 rad, is arg GH's
    rounding to 1e-5 of itself, which no certificate settles to 1e-12: the per-loop search takes it."""
    network = unity_feedback(["k*(s+3)/(s**2*(s+1)*(s+100))"])
    found = _check_against_per_loop(network, {"k": np.array([1e-20, 1e-3, 1.0])})
    assert [sample is None or sample.batched for sample in found] == [False, False, True]


ROW_KINDS = (
    "gain_margin",
    "gain_margin_db",
    "phase_margin",
    "phase_margin_deg",
    "attenuation_margin",
    "modal_peak_db",
    "modal_peak_phase_deg",
    "crossover_frequency",
)


def test_rows_read_from_the_arrays_equal_each_samples_rows():
    """Issue 53: `engine.slp.measures.frequency_values` reads a row of every sample from the
    batch's arrays (`batch_loops`, attenuation margins asked for) as `frequency_value` reads it
    from the sample's `Margins` (`BatchLoops.loop`), exactly: same pick, same tie, same absence.
    Random cascades with light pairs, random bands, both directions; a crossover absent from its
    band is flagged (its absence value reads the grid response)."""
    from engine.margins.batch import batch_loops
    from engine.slp.measures import Spec, frequency_value, frequency_values

    checked = present = 0
    for seed in range(6):
        rng = np.random.default_rng(seed)
        blocks, values = random_cascade_structure(rng)
        forms = batch_pole_zero(unity_feedback(blocks), "e", _samples(values, 30, 0.3, rng))
        loops = batch_loops(forms, attenuation=True)
        for kind in ROW_KINDS:
            low = float(10 ** rng.uniform(-3, 1))
            spec = Spec(
                "row", kind, 0, None, low, low * 10 ** rng.uniform(0.5, 4), bool(rng.random() < 0.5), None, None
            )
            got, at, flagged = frequency_values(spec, loops)
            for k in np.flatnonzero(loops.found & ~flagged).tolist():
                want = frequency_value(spec, loops.loop(k).margins, None)
                assert (got[k], at[k]) == pytest.approx(want, rel=1e-15, nan_ok=True), (seed, kind, k)
                checked += 1
                present += not np.isnan(at[k])
            assert all(
                not any(spec.low <= m.frequency <= spec.high for m in loops.loop(k).margins.phase)
                for k in np.flatnonzero(loops.found & flagged).tolist()
            )
    assert checked >= 0.7 * 6 * 30 * len(ROW_KINDS) and present >= 0.3 * checked  # rows found, not only absent


@pytest.mark.parametrize("n", [1, 2, 5, 27])
def test_every_polynomial_leaving_one_root_out_is_made_bit_for_bit(n):
    """The stationary points' numerators (sum of w_i times the polynomial of the other roots):
    every leave-one-out polynomial made at once, equal bit for bit to the product (x - r) times the
    polynomial so far, one root after the other (a plain loop here), over roots from 1e-3 to 1e3."""
    rng = np.random.default_rng(n)
    t = rng.normal(size=(6, n)) * 10 ** rng.uniform(-3, 3, (6, n)) + 1j * rng.normal(size=(6, n))
    got = leave_one_out(t)
    for s in range(6):
        for i in range(n):
            want = np.array([1.0 + 0j])
            for root in np.delete(t[s], i):
                want = np.concatenate([want, [0]]) - root * np.concatenate([[0], want])
            assert np.array_equal(got[i, :, s], want), (s, i)


def test_searched_samples_of_realized_forms_keep_their_own_record():
    """With realizations' forms (``exact``), a sample the batch's certificate left to the per-loop
    search (a near-tangent crossover) keeps that search's record, its margins polished: not batched,
    its stability margins kept (they were dropped and the sample called batched)."""
    from engine.loop.batch_realization import batch_loop_realization
    from engine.loop.batch_realized_forms import realized_forms
    from engine.margins.batch import POLISH_REACH, batch_loops, sample_loop

    network = unity_feedback(["k", "25/(s**2 + 0.1*s + 25)", "1/(s/1000 + 1)"])
    peak = max(
        abs(m.gh) for m in margins(loop_model(network, "e", OMEGA, {"k": 1.0}), attenuation_above=0.0).attenuation
    )
    k = (1 + np.linspace(-1e-14, 1e-14, 5)) / peak
    exact = realized_forms(batch_loop_realization(network, "e", {"k": k}), network.signal("e"))
    loops = batch_loops(exact.forms, attenuation=True, exact=exact)
    searched = np.flatnonzero(loops.found & ~loops.batched).tolist()
    assert searched
    for s in searched:
        got, own = loops.loop(s), sample_loop(exact.forms, s)
        assert not got.batched
        assert got.margins.stability == own.margins.stability and got.margins.stability
        for family in ("gain", "phase", "attenuation"):  # polished: moved by at most POLISH_REACH
            mine, its = getattr(got.margins, family), getattr(own.margins, family)
            assert [m.frequency for m in mine] == pytest.approx([m.frequency for m in its], rel=POLISH_REACH)
