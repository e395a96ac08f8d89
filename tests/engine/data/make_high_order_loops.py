"""Writes high_order_loops.json: high-order loops typed as one factored expression (48-58
poles, corners 1e3..1e4 rad/s, light damping, right-half-plane factors, 0-3 integrators,
loop gains from 1e-186 to 1e200) and their exact closed-loop poles: the roots of
D + K N multiplied out in 120-digit arithmetic by mpmath's polyroots (minutes: kept as data).

Run from the repository: .venv/bin/python tests/engine/data/make_high_order_loops.py
"""

from __future__ import annotations

import json
from pathlib import Path

import mpmath as mp
import numpy as np

CASES = [(1, 1), (1, 5), (1, 9), (1, 12), (1, 25), (2, 15), (2, 23), (3, 4)]  # (seed, draw)


def loop(rng: np.random.Generator) -> tuple[str, float, list[complex], list[complex]]:
    """The text, and its gain, zeros and poles."""
    n_poles, integrators = int(rng.integers(48, 59)), int(rng.integers(0, 4))
    n_zeros = int(rng.integers(0, n_poles - integrators - 1))

    def factors(n: int) -> tuple[list[str], list[complex]]:
        texts, roots = [], []
        while n > 0:
            w = 10 ** rng.uniform(3, 4)
            if n >= 2 and rng.random() < 0.6:
                z = 10 ** rng.uniform(-3, -0.1)
                texts.append(f"(s**2+{2 * z * w:.6g}*s+{w * w:.6g})")
                roots += list(np.roots([1.0, float(f"{2 * z * w:.6g}"), float(f"{w * w:.6g}")]))
                n -= 2
            else:
                sign = 1 if rng.random() < 0.8 else -1
                texts.append(f"(s{'+' if sign > 0 else '-'}{w:.6g})")
                roots.append(-sign * float(f"{w:.6g}"))
                n -= 1
        return texts, roots

    zero_texts, zeros = factors(n_zeros)
    pole_texts, poles = factors(n_poles - integrators)
    scale = [float(f"{10 ** rng.uniform(-3, 3):.4g}")]
    scale += [float(f"{1 / 10 ** rng.uniform(3, 4):.5g}") for _ in range(n_poles - integrators - n_zeros)]
    den = (f"s**{integrators}*" if integrators else "") + "*".join(pole_texts)
    text = "*".join(f"{c:.5g}" for c in scale) + "*" + "*".join(zero_texts or ["1"]) + f"/({den})"
    return text, float(np.prod(scale)), zeros, poles + [0.0] * integrators


def exact_poles(text_gain: float, zeros: list[complex], poles: list[complex]) -> list[complex]:
    mp.mp.dps = 120

    def expand(roots: list[complex]) -> list:
        c = [mp.mpc(1)]
        for r in roots:
            c = [a - mp.mpc(complex(r)) * b for a, b in zip(c + [0], [0] + c)]
        return c

    d, n = expand(poles), [mp.mpf(text_gain) * x for x in expand(zeros)]
    n = [0] * (len(d) - len(n)) + n
    p = [mp.re(a + b) for a, b in zip(d, n)]
    return [complex(r) for r in mp.polyroots(p, maxsteps=2000, extraprec=1500)]


def origin_roots(gain: float, zeros: list[complex], poles: list[complex]) -> list[complex]:
    """The k roots about the origin of a type-k loop at a small gain, in closed form:
    s^k R(s) + K N(s) = 0 with |s| far below every corner gives s^k = -K N(0)/R(0), exact to
    |s|/corner (1e-100 and less here); polyroots at 120 digits cannot resolve roots that small
    beside roots of 1e4."""
    mp.mp.dps = 60
    k = sum(1 for p in poles if p == 0)
    rest = [p for p in poles if p != 0]
    value = -mp.mpf(gain) * mp.fprod(-mp.mpc(complex(z)) for z in zeros) / mp.fprod(-mp.mpc(complex(p)) for p in rest)
    radius, angle = abs(value) ** (mp.mpf(1) / k), mp.arg(value)
    return [complex(radius * mp.expj((angle + 2 * mp.pi * j) / k)) for j in range(k)]


def with_origin_roots(roots: list[complex], gain: float, zeros: list[complex], poles: list[complex]) -> list[complex]:
    """``roots`` with its k smallest replaced by `origin_roots` when those are below 1e-30."""
    k = sum(1 for p in poles if p == 0)
    if not k:
        return roots
    near = origin_roots(gain, zeros, poles)
    if max(abs(r) for r in near) >= 1e-30:
        return roots
    return sorted(roots, key=abs)[k:] + near


def main() -> None:
    out = []
    for seed, draw in CASES:
        rng = np.random.default_rng(seed)
        for _ in range(draw + 1):
            text, gain, zeros, poles = loop(rng)
        roots = with_origin_roots(exact_poles(gain, zeros, poles), gain, zeros, poles)
        out.append({"seed": seed, "draw": draw, "text": text, "poles": [[r.real, r.imag] for r in roots]})
    (Path(__file__).parent / "high_order_loops.json").write_text(json.dumps(out, indent=1) + "\n")


if __name__ == "__main__":
    main()
