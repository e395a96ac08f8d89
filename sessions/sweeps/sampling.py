"""A tolerance study's samples: each parameter's law, uniform within +-P % of its
value (NAME=+-P%) or normal with a standard deviation of P % of it
(NAME=normal:P%), drawn at random or by Latin hypercube, from a seed: the same
seed, laws and sample count draw the same samples.

A sample is the relative deviations of the parameters' values (a value times
1 + deviation); a parameter with a value per flight condition draws one deviation
per condition.  At random the draws go sample by sample, parameter by parameter in
the session's order (as the uniform studies of earlier versions drew them: their
seeds replay).  A Latin hypercube splits each deviation's probability into as many
strata as samples and puts one sample in each (a random permutation per deviation,
a uniform point within each stratum), drawn deviation by deviation.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from sessions.errors import SessionError
from sessions.format.limits import MAX_SAMPLES

LAWS = ("uniform", "normal")
SAMPLINGS = ("random", "lhs")
FORMS = "write NAME=+-10% (uniform within +-10 %) or NAME=normal:5% (sigma 5 %)"


@dataclass(frozen=True)
class Tolerance:
    """One parameter's law: uniform within +-``fraction`` of its value, or normal with
    a standard deviation of ``fraction`` of it."""

    name: str
    law: str
    fraction: float


def parse_tolerance(text: str) -> Tolerance:
    """NAME=+-P% (or ±P%, uniform:P%) and NAME=normal:P%; P without % is a fraction."""
    name, sep, spec = text.partition("=")
    law, colon, amount = spec.strip().partition(":")
    law, amount = (law.strip().lower(), amount.strip()) if colon else ("uniform", spec.strip())
    amount = amount.removeprefix("+-").removeprefix("±") if law == "uniform" else amount
    try:
        fraction = float(amount.removesuffix("%")) / (100.0 if amount.endswith("%") else 1.0)
    except ValueError:
        raise SessionError(f"--tolerance {text!r}: {FORMS}") from None
    if not sep or not name.strip() or law not in LAWS or not math.isfinite(fraction) or fraction < 0:
        raise SessionError(f"--tolerance {text!r}: {FORMS}")
    return Tolerance(name.strip(), law, fraction)


def parse_tolerances(texts: Sequence[str]) -> dict[str, Tolerance]:
    """Each parameter's law by name; a parameter named twice is refused."""
    laws: dict[str, Tolerance] = {}
    for text in texts:
        tolerance = parse_tolerance(text)
        if tolerance.name in laws:
            raise SessionError(f"--tolerance: {tolerance.name} is given twice")
        laws[tolerance.name] = tolerance
    return laws


def deviations(
    laws: Sequence[Tolerance], sizes: Sequence[int], samples: int, sampling: str = "random", seed: int = 0
) -> list[np.ndarray]:
    """Per law (in the session's parameter order), the samples' relative deviations:
    an array of ``samples`` rows and ``sizes[k]`` columns (one per flight condition of a
    parameter with a value per condition)."""
    if sampling not in SAMPLINGS:
        raise SessionError(f"sampling {sampling!r}: random or lhs")
    if not 1 <= samples <= MAX_SAMPLES:  # a float a sample and parameter drawn at once: memory bounded
        raise SessionError(f"--samples: {samples} is not in 1..{MAX_SAMPLES}")
    rng = np.random.default_rng(seed)
    if sampling == "lhs":
        return [_hypercube(rng, law, size, samples) for law, size in zip(laws, sizes)]
    if len({law.law for law in laws}) == 1:  # one law: every sample's draws in one call, the same stream
        return _all_at_random(rng, laws, sizes, samples)
    out = [np.empty((samples, size)) for size in sizes]
    for k in range(samples):
        for law, drawn in zip(laws, out):
            drawn[k] = _at_random(rng, law, drawn.shape[1])
    return out


def _at_random(rng: np.random.Generator, law: Tolerance, size: int) -> np.ndarray:
    if law.law == "normal":
        return rng.normal(0.0, law.fraction, size)
    return rng.uniform(-law.fraction, law.fraction, size)


def _all_at_random(
    rng: np.random.Generator, laws: Sequence[Tolerance], sizes: Sequence[int], samples: int
) -> list[np.ndarray]:
    """`deviations` at random when every law is of one kind: the draws a sample at a time, law
    after law (the loop's order), made by one call over a (samples, columns) array, whose
    values come from the generator's stream in that order by the same formula (loc + scale *
    a standard normal, low + (high - low) * a uniform double), so the same bits (1 000 000
    samples: 15 s -> 0.1 s)."""
    fractions = np.repeat([law.fraction for law in laws], sizes)
    if laws[0].law == "normal":
        drawn = rng.normal(0.0, fractions, (samples, fractions.size))
    else:
        drawn = rng.uniform(-fractions, fractions, (samples, fractions.size))
    return np.split(drawn, np.cumsum(sizes)[:-1], axis=1)


def _hypercube(rng: np.random.Generator, law: Tolerance, size: int, samples: int) -> np.ndarray:
    """Each column: one sample in each of ``samples`` equally likely strata."""
    columns = []
    for _ in range(size):
        strata = rng.permutation(samples)
        columns.append(_quantile(law, (strata + rng.random(samples)) / samples))
    return np.column_stack(columns)


def _quantile(law: Tolerance, u: np.ndarray) -> np.ndarray:
    """The relative deviation at cumulative probability ``u`` (0 <= u < 1) of a law."""
    if law.law == "normal":
        from scipy.special import ndtri

        return law.fraction * ndtri(np.maximum(u, np.finfo(float).tiny))  # u = 0 (one in 2**53): not -inf
    return law.fraction * (2.0 * u - 1.0)
