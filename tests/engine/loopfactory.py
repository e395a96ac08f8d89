"""Random and reference loops for the margin tests (seeded, reproducible)."""

from __future__ import annotations

import numpy as np

from engine.analysis import unity_feedback
from engine.loop.responses import LoopModel
from engine.model.network import check_grid


def random_poly(rng: np.random.Generator, order: int, unstable: bool) -> np.ndarray:
    """A real polynomial of the given order with real roots and complex pairs,
    damping down to 0.005, natural frequencies 0.1..100 rad/s."""
    roots: list[complex] = []
    while len(roots) < order:
        wn = 10 ** rng.uniform(-1, 2)
        if order - len(roots) >= 2 and rng.random() < 0.6:
            zeta = 10 ** rng.uniform(np.log10(0.005), 0)
            zeta = min(zeta, 0.99)
            sign = -1.0 if (unstable and rng.random() < 0.3) else 1.0
            re, im = -sign * zeta * wn, wn * np.sqrt(1 - zeta**2)
            roots += [complex(re, im), complex(re, -im)]
        else:
            sign = -1.0 if (unstable and rng.random() < 0.3) else 1.0
            roots.append(complex(-sign * wn, 0.0))
    return np.real(np.poly(roots))


def random_loop(seed: int) -> tuple[np.ndarray, np.ndarray]:
    """(num, den) descending, order 1..12, proper, about half with unstable roots."""
    rng = np.random.default_rng(seed)
    order = int(rng.integers(1, 13))
    nzeros = int(rng.integers(0, order + 1))
    unstable = rng.random() < 0.5
    den = random_poly(rng, order, unstable)
    num = random_poly(rng, nzeros, unstable) if nzeros else np.ones(1)
    w0 = 10 ** rng.uniform(-0.5, 1.5)
    gain = 10 ** rng.uniform(-1, 1) / abs(np.polyval(num, 1j * w0) / np.polyval(den, 1j * w0))
    return gain * num, den


def poly_text(c: np.ndarray, x: str = "s") -> str:
    """Descending coefficients as an expression (full repr precision)."""
    n = len(c) - 1
    return "(" + " + ".join(f"({float(v)!r})*{x}**{n - k}" for k, v in enumerate(c)) + ")"


def loop_network(num: np.ndarray, den: np.ndarray):
    return unity_feedback([f"{poly_text(num)}/{poly_text(den)}"])


def tabulated_loop(omega, gh) -> LoopModel:
    """A tabulated open loop (no exact evaluator): what a table of GH(j omega) gives the margins."""
    return LoopModel(check_grid(omega), np.asarray(gh, dtype=complex))


def random_cascade_structure(rng: np.random.Generator) -> tuple[list[str], dict[str, float]]:
    """A cascade of two proper factored blocks with parameters: a gain, real zeros and poles,
    lightly damped pairs, maybe an integrator; the nominal values."""
    values = {"k": float(10 ** rng.uniform(-0.5, 1.5)), "q": float(10 ** rng.uniform(0, 2))}
    zeros = int(rng.integers(0, 3))
    numerator, poles = ["k"], ["s"] if rng.random() < 0.5 else []
    for j in range(zeros):
        values[f"z{j}"] = float(10 ** rng.uniform(-1, 1.5))
        numerator.append(f"(s/z{j} + 1)")
    for j in range(zeros + int(rng.integers(0, 2))):
        values[f"p{j}"] = float(10 ** rng.uniform(-1, 2))
        poles.append(f"(s/p{j} + 1)")
    for j in range(int(rng.integers(0, 3))):
        values[f"w{j}"], values[f"d{j}"] = float(10 ** rng.uniform(-0.5, 2)), float(10 ** rng.uniform(-2.5, -0.5))
        poles.append(f"(s**2/w{j}**2 + 2*d{j}*s/w{j} + 1)")
    blocks = ["*".join(numerator) + ("/(" + "*".join(poles) + ")" if poles else ""), "1/(s/q + 1)"]
    return blocks, values
