"""An expression's pole-zero form, read factor by factor from its tree.

Expanding a product such as (s + 0.001)(s + 0.002)...(s^2 + ...) into one
polynomial and asking for its roots loses digits: the roots of a polynomial
of degree 16 given by its coefficients can be wrong in the third digit when
they cluster.  The tree of a typed expression usually keeps the factors, so
the roots are taken where they are: products, quotients and integer powers
combine root lists; a sum (or a number, a name, the variable) is folded to
its own, small polynomial ratio and only its roots are computed, those of a
sum made accurate on the sum itself, term by term (`_sum_zeros`: the
numerator of a sum of light, close modes places its zeros to 1e-6..1e-2).  Equal
roots of the numerator and the denominator cancel (H((1 + w)/(1 - w)) has
(1 - w) factors that cancel exactly), within `CANCEL` relative.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from engine.derived import Form
from engine.errors import ExpressionError
from engine.model.expressions import Expression, Node
from engine.model.folding import to_rational
from engine.model.paired_product import PairedProduct, reciprocal_sum
from engine.numerics.aberth import aberth
from engine.numerics.fraction_sums import conjugate_closed, factored_sum_zeros
from engine.numerics.polynomials import trim

CANCEL = 1e-10  # relative distance at which a zero and a pole are the same root
MAX_ORDER = 400  # roots of one block: beyond, its realization alone would take minutes


@dataclass(frozen=True)
class PoleZero:
    """gain * prod(x - zeros) / prod(x - poles)."""

    gain: float
    zeros: NDArray[np.complex128]
    poles: NDArray[np.complex128]

    def __mul__(self, other: PoleZero) -> PoleZero:
        return PoleZero(
            self.gain * other.gain, np.concatenate([self.zeros, other.zeros]), np.concatenate([self.poles, other.poles])
        )

    def reciprocal(self) -> PoleZero:
        if self.gain == 0:
            raise ExpressionError("division by zero")
        return PoleZero(1.0 / self.gain, self.poles, self.zeros)

    def power(self, k: int) -> PoleZero:
        base = self if k >= 0 else self.reciprocal()
        k = abs(k)
        if max(base.zeros.size, base.poles.size) * k > MAX_ORDER:
            raise ExpressionError(
                f"order {max(base.zeros.size, base.poles.size) * k} is beyond the limit of {MAX_ORDER} for one block"
            )
        with np.errstate(all="ignore"):
            gain = float(np.float64(base.gain) ** k)  # a Python float's ** raises OverflowError
        return PoleZero(gain, np.tile(base.zeros, k), np.tile(base.poles, k))

    def evaluate(self, x: NDArray[np.complex128]) -> tuple[NDArray[np.complex128], NDArray[np.complex128]]:
        """The value and d/dx at ``x`` (`engine.model.paired_product`: no partial product over- or
        underflows where a tree's product of many factors can, logarithms beyond the range)."""
        x = np.asarray(x, dtype=complex)
        terms = PairedProduct(self.gain, self.zeros, self.poles).terms(x.ravel())
        with np.errstate(all="ignore"):
            return terms.value.reshape(x.shape), (terms.value * terms.slope).reshape(x.shape)

    def cancelled(self) -> PoleZero:
        """Without the zero-pole pairs that are the same root (each zero in turn takes the first
        pole left that is it within CANCEL, as `_matching`; all the distances in one array)."""
        zeros, poles = np.asarray(self.zeros, dtype=complex), np.asarray(self.poles, dtype=complex)
        with np.errstate(invalid="ignore"):
            close = np.abs(zeros[:, None] - poles[None, :]) <= CANCEL * np.maximum(1.0, np.abs(poles))[None, :]
        if not close.any():
            return PoleZero(self.gain, zeros, poles)
        left, kept = np.ones(poles.size, dtype=bool), np.ones(zeros.size, dtype=bool)
        for i in np.flatnonzero(close.any(axis=1)):
            match = np.flatnonzero(close[i] & left)
            if match.size:
                left[match[0]], kept[i] = False, False
        return PoleZero(self.gain, zeros[kept], poles[left])


POLE_ZERO: Form[PoleZero] = Form("pole zero")


def pole_zero(expression: Expression, params: Mapping[str, float]) -> PoleZero:
    """The expression's gain, zeros and poles, factor by factor, cancelled
    (kept on the expression for its last parameter values: the realization
    and the pole polishing both ask)."""
    return expression.at(POLE_ZERO, params, lambda: _checked(expression, params))


def _checked(expression: Expression, params: Mapping[str, float]) -> PoleZero:
    try:
        with np.errstate(all="ignore"):
            form = _node(expression.root, params)
    except ExpressionError as exc:
        if exc.expression:
            raise
        raise ExpressionError(str(exc), expression.text) from None
    if not (np.isfinite(form.gain) and np.all(np.isfinite(form.zeros)) and np.all(np.isfinite(form.poles))):
        raise ExpressionError(
            f"its numbers leave the floating-point range (gain {form.gain:.3g}, roots beyond 1e308 or not numbers)",
            expression.text,
        )
    order = max(form.zeros.size, form.poles.size)
    if order > MAX_ORDER:
        raise ExpressionError(f"order {order} is beyond the limit of {MAX_ORDER} for one block", expression.text)
    return form.cancelled()


def _node(node: Node, params: Mapping[str, float]) -> PoleZero:
    if node.op == "mul":
        return _node(node.args[0], params) * _node(node.args[1], params)
    if node.op == "div":
        return _node(node.args[0], params) * _node(node.args[1], params).reciprocal()
    if node.op == "pow":
        return _node(node.args[0], params).power(node.exponent)
    if node.op == "neg":
        inner = _node(node.args[0], params)
        return PoleZero(-inner.gain, inner.zeros, inner.poles)
    if node.op in ("add", "sub"):
        return _sum(signed_terms(node), params)
    return _leaf(node, params)


def _leaf(node: Node, params: Mapping[str, float]) -> PoleZero:
    """A number, a parameter or the variable."""
    none = np.zeros(0, dtype=complex)
    if node.op == "var":
        return PoleZero(1.0, np.zeros(1, dtype=complex), none)
    value = float(to_rational(node, params).num[0])
    if not np.isfinite(value):
        raise ExpressionError("polynomial coefficients overflow")
    return PoleZero(value, none, none)


def signed_terms(node: Node) -> list[tuple[float, Node]]:
    """A run of + and - as its signed terms (a - (b - c) is a - b + c)."""
    out, stack = [], [(1.0, node)]
    while stack:
        sign, item = stack.pop()
        if item.op in ("add", "sub"):
            stack.append((sign if item.op == "add" else -sign, item.args[1]))
            stack.append((sign, item.args[0]))
        else:
            out.append((sign, item))
    return out


def _sum(terms: list[tuple[float, Node]], params: Mapping[str, float]) -> PoleZero:
    """A sum over the least common denominator of its terms: a pole that terms share (the
    same root, within CANCEL) is one pole of the sum, not a pole of each (over the product
    of the denominators, Z^2 - 0.5 Z with Z = (1 + w)/(1 - w) had a third pole at w = 1 and
    a zero beside it, a pair that no longer cancelled once the roots were recomputed).
    Only the numerator is multiplied out; the terms' own factors are kept as roots."""
    typed = _typed_coefficients(terms, params)
    if typed is not None:  # its numerator is what was typed: its roots stand
        return PoleZero(float(typed[0]), _numerator_roots(typed), np.zeros(0, dtype=complex))
    forms = [(sign, _node(term, params)) for sign, term in terms]
    common: list[complex] = []
    for _, form in forms:
        missing = list(form.poles)
        for p in common:
            k = _matching(missing, p)
            if k is not None:
                missing.pop(k)
        common += missing
    numerator = np.zeros(1)
    for sign, form in forms:
        rest = list(common)
        for p in form.poles:
            rest.pop(_matching(rest, p))
        term = sign * form.gain * np.poly(np.concatenate([form.zeros, np.array(rest, dtype=complex)])).real
        numerator = np.polyadd(numerator, term)
    numerator = trim(numerator)
    zeros = _numerator_roots(numerator)
    if not _typed_polynomial(forms):  # a typed polynomial's numerator is what was typed: its roots stand
        zeros = _origin_exact(forms, common, _sum_zeros(forms, common, zeros))
    return PoleZero(float(numerator[0]), zeros, np.array(common, dtype=complex))


def _numerator_roots(numerator: NDArray) -> NDArray:
    """The roots of a sum's multiplied-out numerator (trimmed), as first estimates."""
    if not np.all(np.isfinite(numerator)):
        raise ExpressionError("polynomial coefficients overflow")
    if numerator.size > 1 and numerator[0] != 0:
        return _roots(numerator).astype(complex)
    return np.zeros(0, dtype=complex)


def _typed_coefficients(terms: list[tuple[float, Node]], params: Mapping[str, float]) -> NDArray | None:
    """The trimmed descending coefficients of a sum whose every term is typed as c x^k, x^k or
    c (c a number or a parameter; `PolynomialTransfer` writes c*x**k), read off the tree with
    no pole-zero form of each term (the same sums, in the same order, as `_sum`'s); None for
    any other sum."""
    monomials = []
    for sign, term in terms:
        typed = monomial(term)
        if typed is None:
            return None
        monomials.append((sign, *typed))
    order = max(k for _, _, k in monomials)
    if order > MAX_ORDER:
        raise ExpressionError(f"order {order} is beyond the limit of {MAX_ORDER} for one block")
    numerator = np.zeros(order + 1)
    for sign, coefficient, k in monomials:
        numerator[order - k] += sign * (1.0 if coefficient is None else _leaf(coefficient, params).gain)
    return trim(numerator)


def monomial(term: Node) -> tuple[Node | None, int] | None:
    """A term typed as c x^k, x^k or c (c a number or a parameter's node): (c or None, k);
    None for any other term."""
    coefficient, power = (term.args[0], term.args[1]) if term.op == "mul" else (None, term)
    if coefficient is not None and coefficient.op not in ("num", "param"):
        return None
    if power.op == "var":
        return coefficient, 1
    if power.op == "pow" and power.args[0].op == "var" and power.exponent >= 0:
        return coefficient, power.exponent
    if coefficient is None and power.op in ("num", "param"):
        return power, 0
    return None


def _typed_polynomial(forms: list[tuple[float, PoleZero]]) -> bool:
    """Is the sum a polynomial typed by its coefficients (terms c x^k)?  Its numerator is then
    exactly what was typed: its roots are neither polished (`_sum_zeros`) nor snapped to the
    origin (`_origin_exact`: a typed constant term is 0 or the sum's backward error at 0 is 1)."""
    return all(form.poles.size == 0 and not np.any(form.zeros) for _, form in forms)


def _origin_exact(forms: list[tuple[float, PoleZero]], common: list[complex], zeros: NDArray) -> NDArray:
    """The zero nearest x = 0 set to 0 when the sum vanishes there to rounding (backward error
    within `BACKWARD`, `_at`): typed decimals such as Z^2 - 1.3 Z + 0.3 with Z = (1 + w)/(1 - w)
    (an integrator, z = 1) leave it at 4e-17, a pole off w = 0 and a gain margin of -322 dB."""
    if zeros.size == 0 or _matching(common, 0j) is not None or np.any(zeros == 0):
        return zeros
    origin = np.zeros(1, dtype=complex)
    if not _at(forms, np.array(common, dtype=complex), origin)[1][0] <= BACKWARD:
        return zeros
    nearest = int(np.argmin(np.abs(zeros)))
    if zeros[nearest].imag != 0:  # a pair about the origin is two roots, not the one there
        return zeros
    snapped = zeros.copy()
    snapped[nearest] = 0.0
    return snapped


def _sum_zeros(forms: list[tuple[float, PoleZero]], common: list[complex], zeros: NDArray) -> NDArray:
    """The zeros of a sum, accurate.  The roots of its expanded numerator (``zeros``) are
    estimates: a sum of lightly damped, closely spaced modes, k0/s + sum k_i/(s^2 + 2 z_i w_i
    s + w_i^2), has zeros between its modes that the numerator's coefficients place to
    1e-6..1e-2 relative with eight modes, to 0.1 with twenty.  They stand when every backward
    error (`_worst_backward_error`) is within `BACKWARD` (most small sums).  Else the zeros
    of the sum's realization (`_realized_zeros`, backward stable) are polished together on
    the sum evaluated term by term (`_at`: never through the expanded numerator),
    and stand when within `BACKWARD`; where they do not, or the sum has no realization (a
    term improper), the numerator's roots are polished too, and of these sets the one with
    the smallest largest backward error is kept (if within `SOUND`: else the numerator's
    roots stand, as where the terms' numbers span 1e-146..1e-1).  Conjugate pairs stay exact pairs.  A root
    of the numerator on one of the common poles (within CANCEL: it cancels) is left as it is
    (a zero of the realization there is checked as any other)."""
    if zeros.size == 0:
        return zeros
    if max(zeros.size, len(common)) > MAX_ORDER:
        return zeros  # the block is refused (`_checked`)
    poles = np.array(common, dtype=complex)
    frozen = np.array([_matching(common, z) is not None for z in zeros.tolist()])
    best, worst = zeros, _worst_backward_error(forms, poles, zeros, frozen)
    if worst <= BACKWARD:
        return zeros  # roots of a well-conditioned numerator (most small sums): already there
    for start, fixed in ((_realized_zeros(forms, common), None), (zeros, frozen)):
        if start is None or start.size != zeros.size:
            continue
        fixed = np.zeros(start.size, dtype=bool) if fixed is None else fixed  # on a pole: no root of the sum's
        polished = aberth(lambda x: _at(forms, poles, x)[0], start, fixed, conjugate=True).roots
        error = _worst_backward_error(forms, poles, polished, fixed)
        if error < worst and error <= SOUND:
            best, worst = polished, error
        if worst <= BACKWARD:
            break
    return best


SOUND = 1e-8  # a polished set with a larger backward error is no set of roots: the numerator's stand
BACKWARD = 1e-14  # |N| / (sum |N_k| + |x| sum |N_k'|) at a zero (`_at`): a few roundings of the terms' factors


def _at(forms: list[tuple[float, PoleZero]], poles: NDArray, x: NDArray) -> tuple[NDArray, NDArray, NDArray]:
    """N'/N and the backward error |N| / (sum |N_k| + |x| sum |N_k'|) at ``x``, for the sum's
    numerator N = sum_k N_k, N_k = term_k * D over the common poles' D = prod(x - p), each
    term evaluated in factored form (never through the expanded numerator): N'/N = f'/f +
    D'/D, N_k'/D = term_k' + term_k D'/D.  The backward error weighs the terms' moduli and
    how much they move when x is rounded (beside a mode of damping zeta, 1 / zeta times
    more), in N, which has no poles: beside a pole of the sum no point looks like a root.
    N'/N is inf where f is 0; the error is inf where it is not finite."""
    value, slope, size = np.zeros(x.shape, complex), np.zeros(x.shape, complex), np.zeros(x.shape)
    with np.errstate(all="ignore"):
        log_d = reciprocal_sum(x, poles)
        for sign, form in forms:
            v, d = form.evaluate(x)
            on_zero = (v == 0) & ~np.isfinite(d)  # x on one of the term's zeros: its other factors' product
            for k in np.flatnonzero(on_zero):
                rest = form.zeros.tolist()
                if x[k] in rest:
                    rest.remove(x[k])
                d[k] = PoleZero(form.gain, np.array(rest, dtype=complex), form.poles).evaluate(x[k : k + 1])[0][0]
            value, slope = value + sign * v, slope + sign * d
            size = size + np.abs(v) + np.abs(x) * np.abs(d + v * log_d)
        ratio = np.divide(slope, value, out=np.full(x.shape, np.inf, dtype=complex), where=value != 0)
        error = np.where(value == 0, 0.0, np.abs(value) / size)
    return ratio + log_d, np.where(np.isfinite(error), error, np.inf), value


def _worst_backward_error(
    forms: list[tuple[float, PoleZero]], poles: NDArray, zeros: NDArray, frozen: NDArray
) -> float:
    """The largest backward error (`_at`) over the zeros not frozen."""
    x = zeros[~frozen]
    return float(np.max(_at(forms, poles, x)[1])) if x.size else 0.0


def _realized_zeros(forms: list[tuple[float, PoleZero]], common: list[complex]) -> NDArray | None:
    """The sum's zeros as the generalized eigenvalues of its terms' realizations in parallel
    (`engine.numerics.fraction_sums.factored_sum_zeros`: backward stable, in factored form),
    less one zero at each pole that two terms share (a state of each), made exactly closed
    under conjugation; None when a term is improper or the eigenvalues are not so closed."""
    found = factored_sum_zeros([(sign * form.gain, form.zeros, form.poles) for sign, form in forms])
    if found is None:
        return None
    kept = found.tolist()
    shared = list(common)
    for p in np.concatenate([form.poles for _, form in forms]).tolist():
        k = _matching(shared, p)
        if k is not None:
            shared.pop(k)  # the first of its kind is the sum's pole
        elif kept:
            kept.pop(int(np.argmin(np.abs(np.array(kept) - p))))
    return conjugate_closed(np.array(kept, dtype=complex))


def _matching(roots: list[complex], root: complex) -> int | None:
    """The index of the first of ``roots`` that is ``root`` within CANCEL of it, or None."""
    return next((k for k, r in enumerate(roots) if abs(root - r) <= CANCEL * max(1.0, abs(r))), None)


def _roots(c: NDArray) -> NDArray:
    """np.roots, without its eigenvalue problem for a first-order factor a x + b
    (b != 0): its companion matrix is the number -b/a, which is the root."""
    if not np.all(np.isfinite(c)):
        raise ExpressionError("polynomial coefficients overflow")
    with np.errstate(all="ignore"):
        if c.size == 2 and c[1] != 0:
            roots = -c[1:] / c[0]
        else:
            try:
                roots = np.roots(c)
            except np.linalg.LinAlgError:  # its companion matrix is not finite: a denormal leading coefficient
                roots = np.full(1, np.inf)
    if not np.all(np.isfinite(roots)):
        raise ExpressionError("a root lies beyond the floating-point range (a leading coefficient near 0?)")
    return roots
