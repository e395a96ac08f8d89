"""Loops in z with a sample time T, analyzed through the bilinear map (report 003's
unscaled w-plane): z = (1 + w)/(1 - w) makes a z loop rational in w (each block's poles
and zeros mapped, `w_block`), and on the unit
circle z = exp(j omega T) the w-plane frequency is nu = tan(omega T/2), so the
grid-free pole-zero search of s loops serves z loops unchanged.  Every frequency it
finds is reported in rad/s, omega = (2/T) atan(nu) exactly, up to the Nyquist frequency
pi/T; a delay margin becomes seconds (the phase margin taken in [0, 2 pi), over omega, as
for s loops) and samples (over T); the
closed-loop poles are z = (1 + w)/(1 - w) of the w-plane ones, with their equivalent
s-plane damping and natural frequency (s = ln(z)/T), stable when |z| < 1 (Re w < 0)."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import replace

import numpy as np
from numpy.typing import NDArray

from engine.analysis import LoopAnalysis, analyze
from engine.errors import EngineError
from engine.margins.search import Band
from engine.model.bilinear import realization_in_w
from engine.model.blocks import ExpressionTransfer, StateSpaceTransfer
from engine.model.factor_text import root_factors
from engine.model.factored import pole_zero
from engine.model.network import Network

CENTRED = 1e-10  # an m-fold root's cluster centred on z = 1 or -1 this closely is there (`_snapped`)
ON_CIRCLE = 1e-12  # a root this near z = 1 or z = -1 is there (the roots of a typed polynomial carry rounding)


def w_plane(network: Network, params: Mapping[str, float]) -> Network:
    """The z network at ``params`` with each block's poles and zeros r mapped to
    w = (r - 1)/(r + 1) (`w_block`): exact, no polynomial expanded."""
    if network.variable != "z":
        raise EngineError(f"a sampled loop is a loop in z, not in {network.variable}")
    entries = []
    for e in network.entries:
        if isinstance(e.transfer, StateSpaceTransfer):  # in w by its realization, kept as state space
            matrices = realization_in_w(*e.transfer.realization())
            entries.append(replace(e, transfer=StateSpaceTransfer(*matrices, source=f"{e.transfer.source}, in z")))
            continue
        if not isinstance(e.transfer, ExpressionTransfer):
            raise EngineError(f"{e.label}: a loop in z takes expressions in z (not a {type(e.transfer).__name__})")
        entries.append(replace(e, transfer=ExpressionTransfer(w_block(e.transfer, params), "w")))
    return Network(network.signals, network.inputs, tuple(entries), "w")


def w_block(transfer: ExpressionTransfer, params: Mapping[str, float]) -> str:
    """A block in z as an expression in w: with z = (1 + w)/(1 - w) each factor z - r is
    (1 + r)(w - (r - 1)/(r + 1))/(1 - w) (z + 1 is 2/(1 - w)), so H(w) is the gain times
    those constants, the mapped factors, and (1 - w) to the relative degree (zeros at
    w = 1, z = infinity): no common factor (1 - w) is left to cancel."""
    form = pole_zero(transfer.expression, params)
    gain = complex(form.gain)
    over, under = [], []
    power = 0  # of (1 - w) over the line
    zeros, poles = _snapped(_snapped(form.zeros, 1.0), -1.0), _snapped(_snapped(form.poles, 1.0), -1.0)
    if np.any(poles == -1):
        raise EngineError(
            f"{transfer.text}: a pole at z = -1 (on the unit circle at the Nyquist frequency) is not analyzed: the loop "
            "has no finite value there"
        )
    for roots, side, sign in ((zeros, over, -1), (poles, under, 1)):
        mapped = []
        for r in roots:
            power += sign
            r = complex(r)  # Python's complex: an overflow is inf, never a numpy warning
            if r == -1:
                gain *= 2.0 if sign < 0 else 0.5
                continue
            gain *= (1 + r) if sign < 0 else 1 / (1 + r)
            mapped.append(0j if r == 1 else (r - 1) / (r + 1))  # z = 1: an integrator, w = 0 exactly
        side += root_factors(mapped, "w")
    if not np.isfinite(gain):
        raise EngineError(f"{transfer.text}: its gain in the w-plane is beyond double precision (above 1.8e308)")
    factors = [f"({float(gain.real)!r})", *over] + ([f"(1-w)^{power}"] if power > 0 else [])
    under += [f"(1-w)^{-power}"] if power < 0 else []
    return "*".join(factors) + (f"/({'*'.join(under)})" if under else "")


def _snapped(roots: NDArray, point: float) -> NDArray:
    """Roots at ``point`` (z = 1 or -1) made exact: m roots typed as an expanded polynomial
    with an m-fold root there scatter by about (kappa eps)^(1/m) around it, kappa the
    polynomial's conditioning (6e-7 from a double root beside roots near 0.99), while their
    centroid stays within about kappa eps of it: m >= 2 roots centred there to `CENTRED` are
    snapped within CENTRED^(1/m); any root within 10 eps^(1/m) is."""
    roots = np.asarray(roots, dtype=complex).copy()
    near = np.abs(roots - point) < 1e-4
    m = int(near.sum())
    if m:
        radius = max(ON_CIRCLE, 10 * np.finfo(float).eps ** (1.0 / m))
        if m >= 2 and abs(np.mean(roots[near]) - point) <= CENTRED:
            radius = max(radius, CENTRED ** (1.0 / m))
        roots[near & (np.abs(roots - point) <= radius)] = point
    return roots


def analyze_sampled(
    network: Network,
    break_at: str,
    omega: NDArray,
    params: Mapping[str, float],
    sample_time: float,
    peak_bands: Sequence[Band] = (),
    skew: float = 0.0,
) -> LoopAnalysis:
    """`engine.analysis.analyze` of a loop in z with sample time T, on the grid's frequencies below
    the Nyquist frequency: its w-plane form (`w_plane`) read as a sampled loop, so every frequency
    comes back in rad/s, delays in seconds and poles in z (`engine.margins.sampled`)."""
    if not (math.isfinite(sample_time) and sample_time > 0):
        raise EngineError(f"a loop in z needs a sample time > 0, not {sample_time!r}")
    omega = np.asarray(omega, dtype=float)
    below = omega[(omega > 0) & (omega < math.pi / sample_time)]
    if below.size < 2:
        raise EngineError(f"the grid has no frequencies below the Nyquist frequency pi/T = {math.pi / sample_time:.6g}")
    sampled = replace(w_plane(network, params), sample_time=sample_time)
    return analyze(sampled, break_at, below, {}, peak_bands, skew)
