"""The measure kinds a target can name, in one table: what each is called
(``name``, ``label``, ``short``), its unit, its natural sense, the desired
value a new target starts with and where it is evaluated.
`engine.design.problem`'s FREQUENCY_MEASURES, TIME_MEASURES,
MEASURE_NAMES and AT_MOST are read from here, as are the engine's
evaluators' lists of what they handle.

Columns:
  * ``short``: the tableau's column label (unique); ``tag``: the prefix of
    slp's row names (COEBRA's listing: GM1, PM1, WC1, ...; unique);
  * ``at_least``: larger is better (False: at most, e.g. peaks, times,
    errors, the attenuation margin); a target's ``sense`` may override it;
  * ``domain``: ``frequency`` (read from the open loop's margins),
    ``time`` (a closed-loop response, which needs a target's ``response``)
    or ``poles`` (the closed-loop poles);
  * ``margin``: the family of `engine.margins.search` a frequency measure is read
    from (G gain, P phase (gain crossovers), S stability, A attenuation and
    modal peaks; None outside the frequency domain), or D: a closed-loop
    peak (`engine.margins.peak_measures`: the disk margin and Mt, each the stability
    margin of a transform of the loop; Ms is family S, 1/Ms being the
    stability margin itself);

Which measures an algorithm's targets may name is the algorithm's to say: its
registration's `TargetUse` (engine.stepping.registry), built from this table.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Literal

import numpy as np
from numpy.typing import NDArray

from engine.errors import EngineError

if TYPE_CHECKING:
    from engine.design.problem import Target

Domain = Literal["frequency", "time", "poles"]
DOMAINS: tuple[Domain, ...] = ("frequency", "time", "poles")


@dataclass(frozen=True)
class MeasureKind:
    """One measure kind: its names, unit, natural sense, default desired value and domain."""

    name: str
    label: str
    short: str
    unit: str
    at_least: bool
    default_desired: float
    domain: Domain
    tag: str = ""
    margin: Literal["G", "P", "S", "A", "D"] | None = None


def _kinds(*rows: tuple) -> dict[str, MeasureKind]:
    return {row[0]: MeasureKind(*row) for row in rows}


# name, label, short, unit, at_least, default desired, domain, slp tag, margin family
MEASURE_KINDS: dict[str, MeasureKind] = _kinds(
    ("gain_margin", "gain margin (distance from -1)", "G", "", True, 0.5, "frequency", "G", "G"),
    ("phase_margin", "phase margin (distance from -1)", "P", "", True, 0.5, "frequency", "P", "P"),
    (
        "stability_margin",
        "stability margin (least distance from -1)",
        "S",
        "",
        True,
        0.5,
        "frequency",
        "S",
        "S",
    ),
    (
        "attenuation_margin",
        "attenuation margin (modal peak |GH|)",
        "A",
        "",
        False,
        0.25,
        "frequency",
        "A",
        "A",
    ),
    ("gain_margin_db", "gain margin", "GM dB", "dB", True, 6.0, "frequency", "GM", "G"),
    ("phase_margin_deg", "phase margin", "PM deg", "deg", True, 30.0, "frequency", "PM", "P"),
    ("crossover_frequency", "gain crossover frequency", "wc", "rad/s", True, 1.0, "frequency", "WC", "P"),
    ("modal_peak_db", "modal peak of |GH|", "peak", "dB", False, -10.0, "frequency", "PK", "A"),
    (
        "modal_peak_phase_deg",
        "phase of the modal peak (|angle GH|)",
        "pk ph",
        "deg",
        False,
        90.0,
        "frequency",
        "PKPH",
        "A",
    ),
    ("disk_margin", "disk margin alpha (balanced, skew 0)", "disk", "", True, 0.5, "frequency", "DM", "D"),
    ("sensitivity_peak", "sensitivity peak Ms = max |S|", "Ms", "", False, 2.0, "frequency", "SPK", "S"),
    (
        "complementary_sensitivity_peak",
        "complementary sensitivity peak Mt = max |T|",
        "Mt",
        "",
        False,
        1.5,
        "frequency",
        "TPK",
        "D",
    ),
    ("delay_margin", "delay margin", "delay", "s", True, 0.1, "frequency", "DLY", "P"),
    (
        "multi_loop_disk_margin",
        "multi-loop disk margin alpha (every break at once, skew 0)",
        "ML disk",
        "",
        True,
        0.3,
        "frequency",
        "MDM",
        "D",
    ),
    ("rise_time", "rise time", "rise", "s", False, 1.0, "time", "TR"),
    ("settling_time", "settling time", "settle", "s", False, 5.0, "time", "TS"),
    ("overshoot_percent", "overshoot", "OS %", "%", False, 20.0, "time", "OS"),
    ("peak_time", "peak time", "t peak", "s", False, 2.0, "time", "TP"),
    ("steady_state_error", "steady-state error", "ss err", "", False, 0.01, "time", "SSE"),
    ("peak_response", "peak |response|", "resp pk", "", False, 1.0, "time", "PEAK"),
    ("mean_square", "mean square response to noise", "msq", "", False, 1.0, "time", "MS"),
    (
        "stability_abscissa",
        "stability abscissa (-max Re of the closed-loop poles)",
        "stab",
        "1/s",
        True,
        0.0,
        "poles",
        "STAB",
    ),
)


# read at every loop break of a condition at once (its `breaks`), not on one loop: the certified
# alpha of `engine.multiloop.network_breaks.diagram_disk_margin`, its worst frequency over the whole axis
EVERY_BREAK = ("multi_loop_disk_margin",)


# What a measure stands at when the loop has no such feature, and why: the one rule every
# verdict reads (the tableau, slp's rows, sweeps, tolerance studies, compare).  A margin
# without its crossing is infinite (met); a peak that does not exist is not above any bound
# (met); a crossover that does not exist is 0 when |GH| < 1 everywhere (no bandwidth: a
# requirement ">= X" unmet, "<= X" met) and infinite when |GH| > 1 everywhere (the reverse).
# A measure not named here is always defined: its absence, a NaN, is never met.
ABSENT: dict[str, tuple[float, str]] = {
    "gain_margin": (math.inf, "no phase crossing: an infinite gain margin"),
    "gain_margin_db": (math.inf, "no phase crossing: an infinite gain margin"),
    "phase_margin": (math.inf, "no gain crossover: an infinite phase margin"),
    "phase_margin_deg": (math.inf, "no gain crossover: an infinite phase margin"),
    "stability_margin": (math.inf, "no local minimum of |1 + GH|: none nearer -1 than the band's ends"),
    "attenuation_margin": (0.0, "no modal peak: nothing to attenuate"),
    "modal_peak_db": (-math.inf, "no modal peak"),
    "modal_peak_phase_deg": (0.0, "no modal peak"),
    "delay_margin": (math.inf, "no gain crossover: any delay is tolerated"),
}
NO_CROSSOVER = {
    "below": (0.0, "no crossover: |GH| < 1 everywhere (no bandwidth)"),
    "above": (math.inf, "no crossover: |GH| > 1 everywhere"),
}


def absence(name: str, magnitudes: NDArray | None = None) -> tuple[float, str] | None:
    """The value a measure stands at when the loop lacks its feature, and why (`ABSENT`);
    a crossover's from the loop's |GH| over the band searched (``magnitudes``); None for a
    measure that is always defined (a NaN of it is never met)."""
    if name == "crossover_frequency":
        if magnitudes is None or not np.any(np.isfinite(magnitudes)):
            return None
        return NO_CROSSOVER["below" if np.nanmax(magnitudes) < 1.0 else "above"]
    return ABSENT.get(name)


def absent_reason(name: str, value: float) -> str | None:
    """Why a row stands at ``value`` when that is its absence value (None otherwise)."""
    if name == "crossover_frequency":
        return next((why for v, why in NO_CROSSOVER.values() if v == value), None)
    found = ABSENT.get(name)
    return found[1] if found is not None and found[0] == value else None


# How an algorithm treats a row whose feature the loop lacks (the absence rule, every algorithm's):
# met and absent, it is judged only (no constraint row, no figure-of-merit term, never blocks a
# step); unmet and absent, it is steered by its surrogate where it has one (a crossover: the
# loop's log |GH(j omega_desired)| toward 0 dB, up from below when |GH| < 1 everywhere, down
# from above when |GH| > 1 everywhere), else judged; a present row is steered on its value.
Role = Literal["steered", "judged", "surrogate"]
SURROGATES: dict[str, str] = {"crossover_frequency": "log|GH(j omega_desired)| toward 0 dB"}


def absence_role(name: str, absent: bool, is_met: bool) -> Role:
    """The absence rule above: how an algorithm treats a row of measure ``name``."""
    if not absent:
        return "steered"
    if is_met or name not in SURROGATES:
        return "judged"
    return "surrogate"


def surrogate_sign(value: float) -> float:
    """The direction a crossover's surrogate log |GH(j omega_desired)| must move to create
    the crossing: up (+1) from its absence below (value 0), down (-1) from above (value inf)."""
    return 1.0 if value == NO_CROSSOVER["below"][0] else -1.0


def met(value: float, desired: float | None, at_least: bool) -> bool:
    """The one verdict: no requirement is met; a NaN (an error, an undefined measure) never is."""
    if desired is None:
        return True
    if math.isnan(value):
        return False
    return value >= desired if at_least else value <= desired


def kind(name: str) -> MeasureKind:
    """The measure kind called ``name``; an `EngineError` listing the known names otherwise."""
    found = MEASURE_KINDS.get(name)
    if found is None:
        raise EngineError(f"unknown measure {name!r}; known: {', '.join(MEASURE_KINDS)}")
    return found


def names(domain: Domain | None = None) -> tuple[str, ...]:
    """Measure names in table order, of one domain when given."""
    if domain is not None and domain not in DOMAINS:
        raise EngineError(f"unknown measure domain {domain!r}; known: {', '.join(DOMAINS)}")
    return tuple(k.name for k in MEASURE_KINDS.values() if domain is None or k.domain == domain)


def shorts() -> dict[str, str]:
    """name -> short label (the tableau's column), for every measure."""
    return {k.name: k.short for k in MEASURE_KINDS.values()}


def default_desired() -> dict[str, float]:
    """name -> the desired value a new target of that measure starts with."""
    return {k.name: k.default_desired for k in MEASURE_KINDS.values()}


@dataclass(frozen=True)
class TargetUse:
    """Which measures an algorithm's targets may name, declared by the algorithm
    (its registration): ``measures`` in table order; ``reads`` False for an algorithm
    that reads no targets (they are kept in the session, unused); ``refusal`` says why a
    measure is refused (a phrase after its name), ``refusals`` for particular measures."""

    measures: tuple[str, ...] = ()
    reads: bool = True
    refusal: str = "is not a measure it reads"
    refusals: tuple[tuple[str, str], ...] = ()
    breaks: bool = False  # whether it reads a target at another loop break than the design's (`break`)

    def accepts(self, name: str) -> bool:
        return self.reads and name in self.measures

    def accepts_target(self, target: Target) -> bool:
        """Whether it reads ``target``: its measure, and its break when it names one."""
        return self.accepts(target.measure) and (target.loop_break is None or self.breaks)

    def check_targets(self, algorithm: str, targets: Iterable[Target]) -> None:
        """`check` of the targets' measures, and an `EngineError` naming a target at a break it does not read."""
        targets = list(targets)
        self.check(algorithm, (t.measure for t in targets))
        for k, t in enumerate(targets):
            if t.loop_break is not None and not self.breaks:
                raise EngineError(
                    f"{algorithm}: target {k} ({t.measure}) is read at the loop break {t.loop_break!r}: "
                    f"{algorithm} reads its targets at the design's break only (slp and cip read them at any break)"
                )

    def why_not(self, name: str) -> str:
        """Why the measure ``name`` is refused (a phrase after the measure's name)."""
        return dict(self.refusals).get(name, self.refusal)

    def check(self, algorithm: str, measures: Iterable[str]) -> None:
        """An `EngineError` naming the first measure not accepted, and what is accepted."""
        for name in measures:
            kind(name)
            if not self.accepts(name):
                listed = f"it accepts {', '.join(self.measures)}" if self.measures else "it accepts no target measures"
                raise EngineError(f"{algorithm}: target measure {name!r} {self.why_not(name)}; {listed}")
