"""The tunable blocks of a network shown as compensators: each block's
coefficients (factored form, as the CIP listing prints them) and each
channel's cascade multiplied out (the listing's MULOUT).

Coefficients are in ascending powers of the frequency variable, as the
listing reads them.  A block is *tunable* when it depends on a parameter;
blocks share a channel when they share a `group` (else each is its own).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from engine.model.blocks import ExpressionTransfer, PolynomialTransfer
from engine.model.network import Network


@dataclass(frozen=True)
class SubCompensator:
    """One tunable block: coefficients in ascending powers, and which
    parameter each coefficient is (None for a number or a derived value)."""

    block: str
    numerator: tuple[float, ...]
    denominator: tuple[float, ...]
    numerator_names: tuple[str | None, ...]
    denominator_names: tuple[str | None, ...]


@dataclass(frozen=True)
class Compensator:
    """A channel's cascade of sub-compensators."""

    group: str
    factors: tuple[SubCompensator, ...]

    def multiplied_out(self) -> tuple[tuple[float, ...], tuple[float, ...]]:
        """Numerator and denominator of the product (ascending powers)."""
        num, den = np.ones(1), np.ones(1)
        for f in self.factors:
            num = np.convolve(num, f.numerator)
            den = np.convolve(den, f.denominator)
        return tuple(num.tolist()), tuple(den.tolist())

    def to_json(self) -> dict:
        num, den = self.multiplied_out()
        return {
            "group": self.group,
            "factors": [
                {"block": f.block, "numerator": list(f.numerator), "denominator": list(f.denominator)}
                for f in self.factors
            ],
            "numerator": list(num),
            "denominator": list(den),
        }


def compensators(network: Network, params: Mapping[str, float]) -> list[Compensator]:
    """Every tunable rational block, grouped into channels in diagram order."""
    groups: dict[str, list[SubCompensator]] = {}
    for entry in network.entries:
        transfer = entry.transfer
        if not transfer.parameters or not isinstance(transfer, ExpressionTransfer):
            continue
        groups.setdefault(entry.group or entry.label, []).append(_sub(entry.label, transfer, params))
    return [Compensator(name, tuple(factors)) for name, factors in groups.items()]


def _sub(label: str, transfer: ExpressionTransfer, params: Mapping[str, float]) -> SubCompensator:
    if isinstance(transfer, PolynomialTransfer):
        num, den = transfer.coefficients(params)

        def names(coefficients: tuple) -> tuple[str | None, ...]:
            return tuple(c if isinstance(c, str) else None for c in coefficients)

        return SubCompensator(label, tuple(num), tuple(den), names(transfer.numerator), names(transfer.denominator))
    r = transfer.rational(params)
    num, den = r.num[::-1].tolist(), r.den[::-1].tolist()
    return SubCompensator(label, tuple(num), tuple(den), (None,) * len(num), (None,) * len(den))


def coefficient_roles(network: Network) -> dict[str, str]:
    """Parameter name -> "numerator" or "denominator" for the coefficients of
    polynomial blocks (other parameters are absent)."""
    role: dict[str, str] = {}
    for entry in network.entries:
        if isinstance(entry.transfer, PolynomialTransfer):
            role.update({c: "numerator" for c in entry.transfer.numerator if isinstance(c, str)})
            role.update({c: "denominator" for c in entry.transfer.denominator if isinstance(c, str)})
    return role


def split_by_role(roles: Mapping[str, str], values: Mapping[str, float]) -> dict[str, dict[str, float]]:
    """Parameter values (e.g. a direction) split into numerator coefficients,
    denominator coefficients and other parameters, as the listing prints
    "partials with respect to X" and "with respect to Y"."""
    split: dict[str, dict[str, float]] = {"numerator": {}, "denominator": {}, "other": {}}
    for name, value in values.items():
        split[roles.get(name.split("[")[0], "other")][name] = value
    return split
