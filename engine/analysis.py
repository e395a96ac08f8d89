"""One call for the whole open-loop picture of a network: margins, crossover,
delay margin, modal peaks, closed-loop poles and the stability verdict."""

from __future__ import annotations

import math
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import ArrayLike, NDArray

from engine.closed_loop.hidden_modes import RELATIVE_TOLERANCE, Factored, hidden_modes
from engine.closed_loop.poles import CONFIRMED, checked, closed_loop_poles, delayed_verdict, z_pole
from engine.errors import EngineError
from engine.loop.design import design
from engine.loop.pole_zero import loop_realization
from engine.loop.realization import Pole, stability, stability_note
from engine.loop.responses import LoopModel, loop_model, open_loop
from engine.margins.disk import DiskMargin, check_skew, disk_transform, from_peak
from engine.margins.peaks import (
    Peak,
    Transform,
    complementary,
    margins_and_peaks,
    peaks_or_failure,
    refined_peaks,
    reported,
    sensitivity,
    unbounded_note,
)
from engine.margins.search import Band, Margins, margins
from engine.margins.values import Margin
from engine.model.blocks import (
    DelayTransfer,
    ExpressionTransfer,
    FrequencyTable,
    StateSpaceTransfer,
    TabulatedTransfer,
)
from engine.model.network import Block, Junction, Network, block_diagram
from engine.model.state_space import given_response


@dataclass(frozen=True)
class ModalPeak:
    """A local maximum of |GH| in a band: frequency (rad/s), level (dB), phase (deg)."""

    frequency: float
    magnitude_db: float
    phase_deg: float


@dataclass(frozen=True)
class LoopAnalysis:
    margins: Margins
    closed_loop_poles: tuple[Pole, ...] | None
    verdict: str  # "stable", "unstable", "marginally stable" or "unknown"
    modal_peaks: tuple[ModalPeak, ...]
    notes: tuple[str, ...]
    disk_margin: DiskMargin | None = None
    sensitivity_peak: Peak | None = None  # Ms = max |S|
    complementary_peak: Peak | None = None  # Mt = max |T|
    hidden: tuple[str, ...] = ()  # per closed-loop pole: "uncontrollable", "unobservable", ... from the loop, or ""

    @property
    def delay_margin(self) -> float | None:
        """The smallest delay margin of the gain crossovers (None: no crossover, any delay is
        tolerated); 0 for an unstable closed loop (already unstable: none is tolerated)."""
        return 0.0 if self.verdict == "unstable" else self.margins.delay_margin


@dataclass(frozen=True)
class LoopCurve:
    """One loop's frequency response as a plot or a report shows it: GH(j omega) of one
    design of one flight condition, its label, its ``role`` (``current``, ``reference``:
    an initial or earlier design, ``condition``: one of several conditions, the
    ``index``-th), and the margins marked on it (None: unmarked).  The workbench's views
    and the design report both draw these (each maps the role to a colour or a line style)."""

    omega: NDArray[np.float64]
    gh: NDArray[np.complex128]
    label: str
    role: str = "current"
    index: int = 0
    margins: Margins | None = None

    @property
    def phase_deg(self) -> NDArray[np.float64]:
        """arg GH (deg), continuous over the curve (numpy's unwrap, from the lowest frequency's branch)."""
        return np.degrees(np.unwrap(np.angle(self.gh)))

    def on_branch(self, angle_deg: float, frequency: float) -> float:
        """``angle_deg`` moved by whole turns onto the curve's branch at ``frequency``: the angle + k 360
        nearest the curve's phase there (`phase_deg` interpolated in log frequency).  The one branch
        rule of what is drawn on a phase axis: the phase-margin marks, the -180 deg and phase-margin
        requirement lines, a cursor's readout."""
        return on_branch(angle_deg, self.omega, self.phase_deg, frequency)


def on_branch(angle_deg: float, omega: ArrayLike, phase_deg: ArrayLike, frequency: float) -> float:
    """``angle_deg`` + k 360 nearest the continuous phase curve ``phase_deg`` (over ``omega``, rad/s) at
    ``frequency``, read by linear interpolation in log frequency (the curve's end value outside it)."""
    w, phase = np.asarray(omega, dtype=float), np.asarray(phase_deg, dtype=float)
    keep = (w > 0) & np.isfinite(phase)
    if not keep.any() or not math.isfinite(angle_deg):
        return float(angle_deg)
    there = float(np.interp(math.log(max(frequency, 1e-300)), np.log(w[keep]), phase[keep]))
    return float(angle_deg + 360.0 * round((there - angle_deg) / 360.0))


def loop_curve(
    network: Network,
    break_at: str,
    omega: NDArray[np.float64],
    params: Mapping[str, float],
    label: str,
    role: str = "current",
    index: int = 0,
    marked: bool = False,
) -> LoopCurve:
    """GH over ``omega`` (an `EngineError` when the loop cannot be evaluated), with its margins
    when ``marked`` (omitted, not an error, when they cannot be found)."""
    gh = open_loop(network, break_at, omega, params, sensitivities=False).value
    found = None
    if marked:
        try:
            found = margins(loop_model(network, break_at, omega, params))
        except EngineError:
            pass
    return LoopCurve(omega, gh, label, role, index, found)


DELAY_FACTOR = re.compile(
    r"exp\(\s*-\s*(?:(?P<a>[0-9.]+(?:[eE][-+]?[0-9]+)?)\s*\*\s*s|s\s*\*\s*"
    r"(?P<b>[0-9.]+(?:[eE][-+]?[0-9]+)?)|(?P<c>s))\s*\)"
)


def split_delays(text: str) -> tuple[str, float]:
    """The expression without its delay factors ``exp(-T*s)`` (``exp(-s*T)``,
    ``exp(-s)``), and the sum of their T.  A factor only: it must multiply
    the rest at the top level (``2*exp(-0.5*s)/(s+1)``), nothing else
    (no other function is read)."""
    total, pieces, last = 0.0, [], 0
    for match in DELAY_FACTOR.finditer(text):
        before, after = text[: match.start()].rstrip(), text[match.end() :].lstrip()
        depth = before.count("(") - before.count(")")
        if depth != 0 or (before and not before.endswith("*")) or (after and after[0] not in "*/"):
            raise EngineError(
                f"{text!r}: a delay exp(-T*s) must be a factor of the whole expression (column {match.start() + 1})"
            )
        total += float(match.group("a") or match.group("b") or 1.0)
        pieces += [text[last : match.start()], "1"]  # the factor becomes 1: the rest reads as before
        last = match.end()
    return "".join(pieces + [text[last:]]), total


def check_not_zero(transfer: ExpressionTransfer, name: str) -> None:
    """A transfer of numbers only that is 0 at every frequency is refused (the loop would be
    open: no margin, no crossover, nothing to design)."""
    if not transfer.parameters and not np.any(transfer.rational({}).num):
        raise EngineError(f"{name} = {transfer.expression.text!r} is 0 at every frequency: the loop is open")


def unity_feedback(
    expressions: Sequence[str],
    variable: str = "s",
    delay: float = 0.0,
    table: FrequencyTable | None = None,
    state_space: StateSpaceTransfer | None = None,
) -> Network:
    """r -> (+) -> e -> product of the expressions (a state space, a delay, a table) -> y,
    with e = r - y; break at 'e'.  Delay factors exp(-T*s) in the expressions
    are read by `split_delays`."""
    if not expressions:
        raise EngineError("give at least one transfer function")
    texts = []
    for text in expressions:
        rest, tau = split_delays(text) if "exp" in text else (text, 0.0)
        texts.append(rest)
        delay += tau
    if delay and variable != "s":
        raise EngineError("a delay needs the variable s (not the w-plane)")
    if not (math.isfinite(delay) and delay >= 0):
        raise EngineError(f"a delay must be finite and >= 0, not {delay!r}")
    chain = [(f"L{k + 1}", ExpressionTransfer(text, variable)) for k, text in enumerate(texts)]
    for name, transfer in chain:
        check_not_zero(transfer, name)
    if state_space is not None and state_space.form.gain == 0:
        raise EngineError(f"{state_space.text} is 0 at every frequency: the loop is open")
    chain += [("plant", state_space)] if state_space is not None else []
    chain += [("delay", DelayTransfer(delay))] if delay else []
    chain += [("table", TabulatedTransfer(table))] if table is not None else []
    blocks, previous = [], "e"
    for k, (name, transfer) in enumerate(chain):
        out = "y" if k == len(chain) - 1 else f"x{k + 1}"
        blocks.append(Block(name, previous, out, transfer))
        previous = out
    return block_diagram(blocks, [Junction("sum", "e", ((1.0, "r"), (-1.0, "y")))], ["r"], variable)


def modal_peaks(model: LoopModel | Margins, bands: Sequence[Band]) -> tuple[ModalPeak, ...]:
    """Local maxima of |GH| inside each band, with the phase there (from the
    margins when they were found with every attenuation maximum)."""
    found = (model if isinstance(model, Margins) else margins(model, attenuation_above=0.0)).attenuation
    out = []
    for m in found:
        if any(b.contains(m.frequency) for b in bands):
            out.append(ModalPeak(m.frequency, float(20 * np.log10(abs(m.gh))), float(np.degrees(np.angle(m.gh)))))
    return tuple(out)


def closed_loop_peaks(
    model: LoopModel, verdict: str, skew: float = 0.0, found: Sequence[Peak] | EngineError | None = None
) -> tuple[DiskMargin | None, Peak | None, Peak | None, tuple[str, ...]]:
    """The disk margin, Ms and Mt of a loop, refined in one search
    (`engine.margins.peaks.refined_peaks`; ``found``: its peaks, or why they failed, when searched
    already with the margins by `margins_with_peaks`); None each with a note when it fails."""
    skew = check_skew(skew)
    if found is None:
        found = peaks_or_failure(lambda: refined_peaks(model, closed_loop_transforms(skew)))
    if isinstance(found, EngineError):
        return None, None, None, (f"no disk margin or sensitivity peaks: {found}",)
    disk, ms, mt = found
    stable = None if verdict == "unknown" else verdict == "stable"
    if verdict == "unstable":
        return from_peak(disk, skew, stable), unstable(ms, "S"), unstable(mt, "T"), (UNSTABLE_NOTE,)
    unbounded = tuple(dict.fromkeys(n for n in map(unbounded_note, (ms, mt)) if n))  # Ms and Mt: one note
    return from_peak(disk, skew, stable), reported(ms), reported(mt), unbounded


def closed_loop_transforms(skew: float) -> list[Transform]:
    """What `closed_loop_peaks` maximizes: |S + (skew - 1)/2| (the disk margin's), |S| and |T|."""
    return [disk_transform(skew), sensitivity, complementary]


def margins_with_peaks(
    model: LoopModel, skew: float, attenuation_above: float | None = None
) -> tuple[Margins, tuple[Peak, ...] | EngineError]:
    """The loop's margins and the peaks `closed_loop_peaks` reads, refined in the same steps
    (`engine.margins.peaks.margins_and_peaks`); in the peaks' place the `EngineError` of their search when
    it fails (`closed_loop_peaks` says why), the margins found once all the same."""
    try:
        transforms = closed_loop_transforms(check_skew(skew))
    except EngineError as exc:
        return margins(model, attenuation_above=attenuation_above), exc
    return margins_and_peaks(model, transforms, attenuation_above)


UNSTABLE_NOTE = (
    "the closed loop is unstable: Ms and Mt are unbounded (S and T have right-half-plane poles) and the "
    "delay margin is 0 (already unstable); the peaks of |S| and |T| on the axis bound nothing"
)


def unstable(peak: Peak, name: str) -> Peak:
    """An unstable closed loop's peak: unbounded, the finite peak on the axis kept in its note."""
    on_axis = f"peak of |{name}| on the axis {peak.value:.6g} at {peak.frequency:.6g} rad/s (bounds nothing)"
    return replace(peak, value=math.inf, notes=peak.notes + (on_axis,))


def _state_space_notes(network: Network) -> list[str]:
    """What each state-space block cannot vouch for (ill-conditioned even balanced)."""
    return [n for e in network.entries if isinstance(e.transfer, StateSpaceTransfer) and (n := e.transfer.note)]


CROSSING_BACKWARD_ERROR = 1e-10  # a crossing of a state-space loop beyond this (relative) is named


def crossing_backward_errors(network: Network, model: LoopModel, found: Margins) -> list[tuple[Margin, float]]:
    """Each gain and phase crossing of a continuous loop with one state-space block, with its relative
    backward error in the coordinates the model was given: GH there (the block by `given_response`,
    the rest of the loop as ``model`` evaluates it), Im GH (a gain crossing) or |GH| - 1 (a phase
    crossing) over the size of GH's change under a relative change of every entry of A, B, C, D;
    [] for other loops."""
    blocks = [e.transfer for e in network.entries if isinstance(e.transfer, StateSpaceTransfer)]
    if len(blocks) != 1 or network.sample_time is not None or network.variable != "s" or model.evaluate is None:
        return []
    block, out = blocks[0], []
    crossings = [m for m in [g for g in found.gain if g.kind == "G"] + list(found.phase) if np.isfinite(m.frequency)]
    if not crossings:
        return []
    omega = np.array([m.frequency for m in crossings])
    loop = np.asarray(model.evaluate(omega)[0], dtype=complex)
    balanced = block.response(1j * omega)[0]
    for m, w, gh_model, g in zip(crossings, omega, loop, balanced):
        if not (np.isfinite(gh_model) and np.isfinite(g) and g != 0):
            continue
        rest = gh_model / g
        value, size = given_response(block.matrices, 1j * w)
        if not (np.isfinite(value) and np.isfinite(size)):  # on an eigenvalue of A as given: not measured
            continue
        gh = rest * value
        residual = abs(gh.imag) if m.kind == "G" else abs(abs(gh) - 1.0)
        out.append((m, residual / (abs(rest) * size) if size > 0 else 0.0))
    return out


def _crossing_note(network: Network, model: LoopModel, found: Margins) -> list[str]:
    """One line: the state-space loop's crossings' largest backward error in the model's coordinates,
    or each beyond `CROSSING_BACKWARD_ERROR` named."""
    errors = crossing_backward_errors(network, model, found)
    if not errors:
        return []
    doubtful = [(m, e) for m, e in errors if not e <= CROSSING_BACKWARD_ERROR]
    if not doubtful:
        largest = max(e for _, e in errors)
        return [
            f"{len(errors)} crossing(s) checked in the state space's own coordinates: relative backward error "
            f"{largest:.1e} at most"
        ]
    named = ", ".join(f"{m.kind} at {m.frequency:.6g} rad/s ({e:.1g})" for m, e in doubtful)
    return [
        f"{len(doubtful)} of {len(errors)} crossing(s) have a relative backward error above {CROSSING_BACKWARD_ERROR:g} "
        f"in the state space's own coordinates: {named}; their digits are not vouched for"
    ]


def analyze(
    network: Network,
    break_at: str,
    omega: ArrayLike,
    params: Mapping[str, float],
    peak_bands: Sequence[Band] = (),
    skew: float = 0.0,
) -> LoopAnalysis:
    """Margins of the loop broken at ``break_at``, and the closed-loop poles
    when rational (first: an improper loop is an error before any search)."""
    pole_list: tuple[Pole, ...] | None = None
    pole_notes: tuple[str, ...] = ()
    verdict = "unknown"
    hidden: tuple[str, ...] = ()
    if network.rational:
        pole_list, pole_notes = checked(network, params, closed_loop_poles(network, params))
        verdict = stability(list(pole_list))
        hidden = fixed_modes(network, break_at, params, pole_list)
        pole_notes = _fixed_notes(pole_list, hidden, pole_notes, network.sample_time)
        pole_notes += tuple(filter(None, [stability_note(list(pole_list))]))
        if network.sample_time is not None:  # stable when |z| < 1: Re w < 0, read above
            pole_list = tuple(z_pole(p, network.sample_time) for p in pole_list)
    model = loop_model(network, break_at, omega, params)
    every, peaks = margins_with_peaks(model, skew, attenuation_above=0.0)
    result = replace(every, attenuation=())
    notes = list(result.notes) + list(pole_notes) + _state_space_notes(network) + _crossing_note(network, model, result)
    if not network.rational:
        notes.append("closed-loop poles need a rational model (no tables, no delays)")
        verdict, how = delayed_verdict(network, params)
        notes += [how] if how else []
    disk, ms, mt, failed = closed_loop_peaks(model, verdict, skew, peaks)
    if every.crossovers_beyond is not None:
        notes.append(
            f"the disk margin, Ms and Mt are those of the searched range (up to {every.crossovers_beyond:.6g} rad/s, "
            "where |GH| >= 1 still): beyond it they are not known"
        )
    return LoopAnalysis(
        result, pole_list, verdict, modal_peaks(every, peak_bands), tuple(notes) + failed, disk, ms, mt, hidden
    )


def fixed_modes(network: Network, break_at: str, params: Mapping[str, float], poles: Sequence[Pole]) -> tuple[str, ...]:
    """Per closed-loop pole, whether the loop broken at ``break_at`` can move it (""), or it is a fixed
    mode uncontrollable or unobservable from the loop (`engine.closed_loop.hidden_modes`); all ""
    when the loop has no realization."""
    try:
        ss = loop_realization(network, break_at, params)
    except EngineError:
        return ("",) * len(poles)
    k = network.signal(break_at)
    b, c = ss.B[:, -1], ss.C[k] / (1.0 - ss.D[k, -1])
    form = design(network, params).loop(break_at).pole_zero
    factored = Factored(form.zeros, form.poles) if form is not None and form.factored else None
    return hidden_modes(ss.A, b, c, [p.value for p in poles], factored)


def _fixed_notes(
    poles: Sequence[Pole], hidden: Sequence[str], notes: tuple[str, ...], sample_time: float | None
) -> tuple[str, ...]:
    """The poles notes with the fixed modes named as such; the note that a pole is no root of the
    characteristic equation dropped when every such pole is a fixed mode (a cancelled factor's root is
    none: that is what it is)."""
    fixed = [(p, h) for p, h in zip(poles, hidden) if h]
    if not fixed:
        return notes
    unexplained = [p for p, h in zip(poles, hidden) if not h and not (p.backward_error or 0.0) <= CONFIRMED]
    kept = notes if unexplained else tuple(n for n in notes if "not roots of the characteristic" not in n)
    named = ", ".join(
        f"{(p.value if sample_time is None else z_pole(p, sample_time).value):.6g} ({h})" for p, h in fixed[:4]
    )
    more = f" and {len(fixed) - 4} more" if len(fixed) > 4 else ""
    return kept + (
        f"{len(fixed)} closed-loop pole(s) are fixed (hidden) modes, which no compensator gain moves: {named}{more} "
        f"from the loop (PBH test on the balanced realization, relative tolerance {RELATIVE_TOLERANCE:g})",
    )
