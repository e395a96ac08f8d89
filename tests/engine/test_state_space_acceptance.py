"""Issue 39's acceptance for plants as state space: random models up to order 80
(python-control's rss for B, C, D; A with lightly damped modes, damping 0.001 to
0.05, and real poles, spread over five decades, seed fixed) analyzed through a
state-space block agree with the same model typed as an expression of factors
(python-control's zeros and poles, the gain matched at a frequency): the gain and
phase margins and their frequencies to 1e-8 relative, the closed-loop verdict the
same, and none refused (the import multiplied a state space out into a polynomial,
refused beyond degree 64, whose coefficients reach 1e62 at order 80 here).

A is rotated by a random orthogonal matrix, so its eigenvalues are well conditioned:
rss's own similarity is not orthogonal, and with eigenvalues conditioned 1e4 any two
methods (python-control's roots and the block's) part in the sixth digit, which
measures the model, not the block.

The 100 models take about 8 s together (marked slow: `make test` runs them, `make
test-fast` does not).
"""

from __future__ import annotations

import control
import numpy as np
import pytest
from scipy import linalg

from engine.analysis import analyze, unity_feedback
from engine.model.blocks import StateSpaceTransfer

MODELS = 100
RTOL = 1e-8
OMEGA = np.geomspace(1e-3, 1e4, 200)


def random_model(seed: int) -> tuple[np.ndarray, ...]:
    """A, B, C, D of order 1..80: A = Q diag(blocks) Q' with Q a random rotation, its blocks
    lightly damped pairs and real poles; B, C, D from control.rss(n, 1, 1)."""
    rng = np.random.default_rng(seed)
    n = 1 + seed * 79 // (MODELS - 1)
    pairs = int(rng.integers(0, n // 2 + 1))
    w, zeta = 10 ** rng.uniform(-2, 3, pairs), rng.uniform(0.001, 0.05, pairs)
    blocks = [np.array([[-z * x, x * np.sqrt(1 - z * z)], [-x * np.sqrt(1 - z * z), -z * x]]) for x, z in zip(w, zeta)]
    blocks += [np.array([[-(10 ** rng.uniform(-2, 3))]]) for _ in range(n - 2 * pairs)]
    q = np.linalg.qr(rng.standard_normal((n, n)))[0]
    np.random.seed(seed)  # rss draws from numpy's global generator
    sys = control.rss(n, 1, 1)
    return q @ linalg.block_diag(*blocks) @ q.T, sys.B, sys.C, sys.D


def factors(roots: np.ndarray) -> list[str]:
    """(s - r) for a real root, (s^2 - 2 Re r s + |r|^2) for a pair (its upper root)."""
    out = []
    for r in roots:
        if r.imag > 0:
            out.append(f"(s**2 + {float(-2 * r.real)!r}*s + {float(abs(r) ** 2)!r})")
        elif r.imag == 0:
            out.append(f"(s + {float(-r.real)!r})")
    return out


def as_factors(A, B, C, D) -> str:
    """The model typed as gain * prod(zero factors) / prod(pole factors), python-control's roots."""
    sys = control.ss(A, B, C, D)
    zeros, poles = sys.zeros(), sys.poles()
    s0 = 1.13j * float(np.exp(np.mean(np.log(np.abs(np.concatenate([zeros, poles]))))))
    gain = (sys(s0) * np.prod(s0 - poles) / np.prod(s0 - zeros)).real
    return f"{float(gain)!r}*" + "*".join(factors(zeros) or ["1"]) + "/(" + "*".join(factors(poles)) + ")"


def margins_of(result) -> tuple[np.ndarray, ...]:
    """Gain margins (frequency, |1/GH|) and phase margins (frequency, degrees)."""
    m = result.margins
    gain = np.array([(g.frequency, 10 ** (-g.gain_db / 20)) for g in m.listed("G")]).reshape(-1, 2)
    phase = np.array([(p.frequency, p.phase_deg) for p in m.phase]).reshape(-1, 2)
    return gain, phase


@pytest.mark.slow
@pytest.mark.parametrize("seed", range(MODELS))
def test_a_state_space_block_has_the_margins_of_its_factored_expression(seed):
    A, B, C, D = random_model(seed)
    through_state_space = analyze(unity_feedback(["1"], state_space=StateSpaceTransfer(A, B, C, D)), "e", OMEGA, {})
    through_factors = analyze(unity_feedback([as_factors(A, B, C, D)]), "e", OMEGA, {})
    assert through_state_space.verdict == through_factors.verdict
    for ours, theirs in zip(margins_of(through_state_space), margins_of(through_factors)):
        assert ours.shape == theirs.shape, (ours, theirs)
        np.testing.assert_allclose(ours[:, 0], theirs[:, 0], rtol=RTOL, atol=0)
    (gain, phase), (gain_ref, phase_ref) = margins_of(through_state_space), margins_of(through_factors)
    np.testing.assert_allclose(gain[:, 1], gain_ref[:, 1], rtol=RTOL)
    np.testing.assert_allclose(phase[:, 1], phase_ref[:, 1], rtol=0, atol=RTOL * 180)


def test_the_models_span_orders_and_decades():
    """The campaign's premise: orders 1 to 80, the largest with modes over five decades."""
    orders = [1 + seed * 79 // (MODELS - 1) for seed in range(MODELS)]
    assert min(orders) == 1 and max(orders) == 80 and len(set(orders)) == 80
    poles = np.abs(np.linalg.eigvals(random_model(MODELS - 1)[0]))
    assert poles.size == 80 and poles.max() / poles.min() > 1e4
