"""The measure kinds a target can name, in one table: what each is called
(``name``, ``label``, ``short``), its unit, its natural sense, the desired
value a new target starts with, where it is evaluated and which algorithms
accept it.  `engine.design.problem`'s FREQUENCY_MEASURES, TIME_MEASURES,
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
  * ``algorithms``: the algorithms whose targets may name the measure (cip:
    distances at one frequency; slp: every measure; qcg and projection read
    no targets); `refusal` says why an algorithm refuses one.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from typing import Literal

from engine.errors import EngineError

Domain = Literal["frequency", "time", "poles"]
DOMAINS: tuple[Domain, ...] = ("frequency", "time", "poles")

# every algorithm the table speaks of, with why it refuses a measure (for messages)
ALGORITHMS: dict[str, str] = {
    "cip": "is not a margin (cip improves gain, phase, stability, attenuation and disk margins, Ms and Mt)",
    "slp": "is not an slp measure",
    "qcg": "is not read by qcg (it minimizes its quadratic cost and reads no targets)",
    "projection": "is not read by projection (it meets its DAE system's constraints and reads no targets)",
}


@dataclass(frozen=True)
class MeasureKind:
    """One measure kind: its names, unit, natural sense, default desired value, domain and algorithms."""

    name: str
    label: str
    short: str
    unit: str
    at_least: bool
    default_desired: float
    domain: Domain
    algorithms: frozenset[str]
    tag: str = ""
    margin: Literal["G", "P", "S", "A", "D"] | None = None


_CIP_SLP = frozenset({"cip", "slp"})
_SLP = frozenset({"slp"})


def _kinds(*rows: tuple) -> dict[str, MeasureKind]:
    return {row[0]: MeasureKind(*row) for row in rows}


# name, label, short, unit, at_least, default desired, domain, algorithms, slp tag, margin family
MEASURE_KINDS: dict[str, MeasureKind] = _kinds(
    ("gain_margin", "gain margin (distance from -1)", "G", "", True, 0.5, "frequency", _CIP_SLP, "G", "G"),
    ("phase_margin", "phase margin (distance from -1)", "P", "", True, 0.5, "frequency", _CIP_SLP, "P", "P"),
    (
        "stability_margin",
        "stability margin (least distance from -1)",
        "S",
        "",
        True,
        0.5,
        "frequency",
        _CIP_SLP,
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
        _CIP_SLP,
        "A",
        "A",
    ),
    ("gain_margin_db", "gain margin", "GM dB", "dB", True, 6.0, "frequency", _CIP_SLP, "GM", "G"),
    ("phase_margin_deg", "phase margin", "PM deg", "deg", True, 30.0, "frequency", _CIP_SLP, "PM", "P"),
    ("crossover_frequency", "gain crossover frequency", "wc", "rad/s", True, 1.0, "frequency", _SLP, "WC", "P"),
    ("modal_peak_db", "modal peak of |GH|", "peak", "dB", False, -10.0, "frequency", _SLP, "PK", "A"),
    (
        "modal_peak_phase_deg",
        "phase of the modal peak (|angle GH|)",
        "pk ph",
        "deg",
        False,
        90.0,
        "frequency",
        _SLP,
        "PKPH",
        "A",
    ),
    ("disk_margin", "disk margin alpha (balanced, skew 0)", "disk", "", True, 0.5, "frequency", _CIP_SLP, "DM", "D"),
    ("sensitivity_peak", "sensitivity peak Ms = max |S|", "Ms", "", False, 2.0, "frequency", _CIP_SLP, "SPK", "S"),
    (
        "complementary_sensitivity_peak",
        "complementary sensitivity peak Mt = max |T|",
        "Mt",
        "",
        False,
        1.5,
        "frequency",
        _CIP_SLP,
        "TPK",
        "D",
    ),
    ("delay_margin", "delay margin", "delay", "s", True, 0.1, "frequency", _SLP, "DLY", "P"),
    ("rise_time", "rise time", "rise", "s", False, 1.0, "time", _SLP, "TR"),
    ("settling_time", "settling time", "settle", "s", False, 5.0, "time", _SLP, "TS"),
    ("overshoot_percent", "overshoot", "OS %", "%", False, 20.0, "time", _SLP, "OS"),
    ("peak_time", "peak time", "t peak", "s", False, 2.0, "time", _SLP, "TP"),
    ("steady_state_error", "steady-state error", "ss err", "", False, 0.01, "time", _SLP, "SSE"),
    ("peak_response", "peak |response|", "resp pk", "", False, 1.0, "time", _SLP, "PEAK"),
    ("mean_square", "mean square response to noise", "msq", "", False, 1.0, "time", _SLP, "MS"),
    (
        "stability_abscissa",
        "stability abscissa (-max Re of the closed-loop poles)",
        "stab",
        "1/s",
        True,
        0.0,
        "poles",
        _SLP,
        "STAB",
    ),
)


# why an algorithm refuses one measure in particular (else ALGORITHMS' general reason)
REFUSALS: dict[tuple[str, str], str] = {
    ("cip", "delay_margin"): "is not a distance cip can push at one frequency (a delay margin is the phase "
    "margin over a crossover frequency that moves with the design); use slp",
}


def refusal(algorithm: str, name: str) -> str:
    """Why ``algorithm`` refuses the measure ``name`` (a phrase after the measure's name)."""
    return REFUSALS.get((algorithm, name), ALGORITHMS[algorithm])


def kind(name: str) -> MeasureKind:
    """The measure kind called ``name``; an `EngineError` listing the known names otherwise."""
    found = MEASURE_KINDS.get(name)
    if found is None:
        raise EngineError(f"unknown measure {name!r}; known: {', '.join(MEASURE_KINDS)}")
    return found


def names(domain: Domain | None = None, algorithm: str | None = None) -> tuple[str, ...]:
    """Measure names in table order, of one domain and/or accepted by one algorithm when given."""
    if domain is not None and domain not in DOMAINS:
        raise EngineError(f"unknown measure domain {domain!r}; known: {', '.join(DOMAINS)}")
    if algorithm is not None and algorithm not in ALGORITHMS:
        raise EngineError(f"unknown algorithm {algorithm!r}; known: {', '.join(ALGORITHMS)}")
    return tuple(
        k.name
        for k in MEASURE_KINDS.values()
        if (domain is None or k.domain == domain) and (algorithm is None or algorithm in k.algorithms)
    )


def shorts() -> dict[str, str]:
    """name -> short label (the tableau's column), for every measure."""
    return {k.name: k.short for k in MEASURE_KINDS.values()}


def default_desired() -> dict[str, float]:
    """name -> the desired value a new target of that measure starts with."""
    return {k.name: k.default_desired for k in MEASURE_KINDS.values()}


def accepts(algorithm: str, name: str) -> bool:
    """Whether ``algorithm``'s targets may name the measure ``name``."""
    return algorithm in kind(name).algorithms


def check_accepted(algorithm: str, measures: Iterable[str]) -> None:
    """An `EngineError` naming the first measure ``algorithm`` does not accept, and what it accepts."""
    if algorithm not in ALGORITHMS:
        raise EngineError(f"unknown algorithm {algorithm!r}; known: {', '.join(ALGORITHMS)}")
    for name in measures:
        if not accepts(algorithm, name):
            accepted = names(algorithm=algorithm)
            listed = f"it accepts {', '.join(accepted)}" if accepted else "it accepts no target measures"
            raise EngineError(f"{algorithm}: target measure {name!r} {refusal(algorithm, name)}; {listed}")
