"""Transfer elements of a plant: rational expressions (polynomial, factored or
free form), state spaces, tabulated frequency responses, and pure delays.

Every transfer answers `evaluate(x, params, with_dvar)` with a `Dual`: its
complex response at the points ``x`` of the frequency variable (``x = j*omega``)
with derivatives with respect to its parameters and, when it can, to ``x``.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from functools import cached_property
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from engine.derived import Derived, Form
from engine.errors import BlockError, ExtrapolationError
from engine.model.expressions import VARIABLES, Dual, Expression
from engine.model.factored import PoleZero, pole_zero
from engine.model.state_space import Response, checked, conditioning_note, pole_zero_form
from engine.numerics.polynomials import Rational, degree

Coefficient = float | str  # a number or the name of a parameter
Compiled = Callable[[NDArray], tuple[NDArray, NDArray | None]]
TWO_PI = 2.0 * np.pi
MAX_TABLE_ROWS = 10_000  # rows of one frequency table (inline or CSV)


def _term(c: Coefficient) -> str:
    return repr(float(c)) if isinstance(c, (int, float)) else str(c)


class ExpressionTransfer:
    """A rational transfer function given by an `Expression`."""

    exact = True
    rational_form = True

    def __init__(self, expression: Expression | str, variable: str = "s"):
        self.expression = expression if isinstance(expression, Expression) else Expression(expression, variable)
        self.parameters = self.expression.parameters
        self._constant: complex | None = None
        if not self.parameters:
            r = self.rational({})  # a zero denominator is an error now, not at the first evaluation
            if degree(r.num) <= 0 and degree(r.den) == 0:
                self._constant = complex(r.num[-1] / r.den[-1])  # a gain or a junction sign

    @property
    def text(self) -> str:
        return self.expression.text

    def evaluate(
        self, x: NDArray, params: Mapping[str, float], with_dvar: bool = False, with_grad: bool = True
    ) -> Dual:
        if self._constant is not None:
            value = np.full(np.shape(x), self._constant)
            return Dual(value, {}, np.zeros_like(value) if with_dvar else None)
        return self.expression.evaluate(x, params, with_dvar, with_grad)

    def compile(self, params: Mapping[str, float]) -> Compiled:
        """Fast (value, d/dx) evaluator for fixed parameters: the expression's tree, and its
        pole-zero form where a product of many factors over- or underflowed in the tree
        (1e200 (s + 3000)^40 / (s^57 ...) is finite while its numerator is not)."""
        tree = self.expression.compile(params)

        def evaluate(x: NDArray) -> tuple[NDArray, NDArray]:
            value, slope = tree(x)
            lost = ~(np.isfinite(value) & np.isfinite(slope))
            if lost.any():
                value, slope = np.array(value, dtype=complex), np.array(slope, dtype=complex)
                value[lost], slope[lost] = pole_zero(self.expression, params).evaluate(np.asarray(x)[lost])
            return value, slope

        return evaluate

    def rational(self, params: Mapping[str, float]) -> Rational:
        """Polynomial ratio for the given parameter values; checks it is usable."""
        r = self.expression.rational(params)
        if r.is_zero_denominator:
            raise BlockError(f"{self.text!r}: denominator is identically zero")
        return r

    def check_proper(self, params: Mapping[str, float], where: str) -> Rational:
        r = self.rational(params)
        if r.relative_degree < 0:
            raise BlockError(
                f"{where}: {self.text!r} is improper (numerator degree "
                f"{degree(r.num)} > denominator degree {degree(r.den)})"
            )
        return r


class PolynomialTransfer(ExpressionTransfer):
    """A ratio of polynomials that remembers its coefficient lists (ascending
    powers), so a compensator can be shown factored and multiplied out."""

    def __init__(self, numerator: Sequence[Coefficient], denominator: Sequence[Coefficient], variable: str = "s"):
        self.numerator = tuple(_coefficient(c, variable) for c in numerator)
        self.denominator = tuple(_coefficient(c, variable) for c in denominator)

        def poly(coefficients: tuple[Coefficient, ...], what: str) -> str:
            if len(coefficients) == 0:
                raise BlockError(f"{what} has no coefficients")
            return "(" + " + ".join(f"{_term(c)}*{variable}**{k}" for k, c in enumerate(coefficients)) + ")"

        super().__init__(f"{poly(self.numerator, 'numerator')}/{poly(self.denominator, 'denominator')}", variable)

    def evaluate(
        self, x: NDArray, params: Mapping[str, float], with_dvar: bool = False, with_grad: bool = True
    ) -> Dual:
        """N(x)/D(x) by Horner's rule, with d/dcoefficient = x^i/D (numerator)
        and -N x^i/D^2 (denominator): no expression tree on this hot path."""
        x = np.asarray(x, dtype=complex)
        num, den = self.coefficients(params)
        n, d = _horner(num, x), _horner(den, x)
        value = n / d
        grad: dict[str, NDArray] = {}
        if with_grad:
            sides = ((self.numerator, 1.0 / d), (self.denominator, -value / d))
            power = np.ones_like(x)
            for i in range(max(len(num), len(den))):
                for coefficients, factor in sides:
                    if i < len(coefficients) and isinstance(coefficients[i], str):
                        name = coefficients[i]
                        grad[name] = grad[name] + power * factor if name in grad else power * factor
                power = power * x
        dvar = None
        if with_dvar:
            dn = _horner([i * c for i, c in enumerate(num)][1:] or [0.0], x)
            dd = _horner([i * c for i, c in enumerate(den)][1:] or [0.0], x)
            dvar = (dn - value * dd) / d
        return Dual(value, grad, dvar)

    def coefficients(self, params: Mapping[str, float]) -> tuple[list[float], list[float]]:
        """Numerator and denominator coefficients (ascending) for parameter values."""
        return (
            [params[c] if type(c) is str else c for c in self.numerator],
            [params[c] if type(c) is str else c for c in self.denominator],
        )


def _coefficient(c: Coefficient, variable: str) -> Coefficient:
    """A polynomial coefficient: a finite number or a parameter's name (never an expression)."""
    if isinstance(c, str):
        if not c.isidentifier() or c in VARIABLES:
            raise BlockError(
                f"coefficient {c[:40]!r} is neither a number nor a parameter name "
                "(write an expression block for a coefficient that is an expression)"
            )
        return c
    if isinstance(c, bool) or not isinstance(c, (int, float)) or not np.isfinite(c):
        raise BlockError(f"coefficient {c!r} is not a finite number")
    return float(c)


def _horner(ascending: Sequence[float], x: NDArray) -> NDArray:
    """sum c_i x^i by Horner's rule (fewer array operations than numpy's polyval)."""
    if len(ascending) == 1:
        return np.full_like(x, ascending[0])
    value = ascending[-1] * x + ascending[-2]
    for c in reversed(ascending[:-2]):
        value = value * x + c
    return value


def polynomial_transfer(
    numerator: Sequence[Coefficient],
    denominator: Sequence[Coefficient],
    order: Literal["ascending", "descending"],
    variable: str = "s",
) -> PolynomialTransfer:
    """A ratio of polynomials from coefficient lists.

    ``order="ascending"`` reads x_0, x_1, ... as the CIP listing does;
    ``order="descending"`` reads the highest power first.
    """
    if order not in ("ascending", "descending"):
        raise BlockError(f"coefficient order must be 'ascending' or 'descending', not {order!r}")
    if order == "descending":
        numerator, denominator = list(numerator)[::-1], list(denominator)[::-1]
    return PolynomialTransfer(numerator, denominator, variable)


@dataclass(frozen=True)
class Factor:
    """One factor of a factored transfer function.

    kind ``time_constant``: (1 + T x); ``root``: (x + a);
    ``second_order``: (x^2/omega^2 + 2 zeta x/omega + 1), COEBRA's shorthand.
    """

    kind: Literal["time_constant", "root", "second_order"]
    T: Coefficient = 0.0
    a: Coefficient = 0.0
    zeta: Coefficient = 0.0
    omega: Coefficient = 1.0

    def text(self, x: str) -> str:
        if self.kind == "time_constant":
            return f"(1 + {_term(self.T)}*{x})"
        if self.kind == "root":
            return f"({x} + {_term(self.a)})"
        if self.kind == "second_order":
            w, z = _term(self.omega), _term(self.zeta)
            return f"({x}**2/{w}**2 + 2*{z}*{x}/{w} + 1)"
        raise BlockError(f"unknown factor kind {self.kind!r}")


def factored_transfer(
    gain: Coefficient = 1.0,
    s_power: int = 0,
    zeros: Sequence[Factor] = (),
    poles: Sequence[Factor] = (),
    variable: str = "s",
) -> ExpressionTransfer:
    """gain * x^s_power * prod(zeros) / prod(poles)."""
    num = [_term(gain)] + [f.text(variable) for f in zeros]
    den = [f.text(variable) for f in poles] or ["1"]
    if s_power > 0:
        num.append(f"{variable}**{s_power}")
    elif s_power < 0:
        den.append(f"{variable}**{-s_power}")
    return ExpressionTransfer(f"{'*'.join(num)}/({'*'.join(den)})", variable)


@dataclass(frozen=True)
class ControllerFactor:
    """A factor of report 001's controller form (eq. 27).

    ``zero``/``pole``: (x/b + 1)^(+1/-1) with b a corner (rad/s);
    ``complex_zero``/``complex_pole``: (x^2/w^2 + 2 zeta x/w + 1)^(+1/-1).
    The listing's parameter kinds: 1 zero, 2 gain, 3 pole, 4/5 complex-zero
    damping/frequency, 6/7 complex-pole damping/frequency.
    """

    kind: Literal["zero", "pole", "complex_zero", "complex_pole"]
    b: Coefficient = 1.0
    damping: Coefficient = 0.5
    frequency: Coefficient = 1.0

    def text(self, x: str) -> str:
        if self.kind in ("zero", "pole"):
            body = f"({x}/{_term(self.b)} + 1)"
        elif self.kind in ("complex_zero", "complex_pole"):
            w, z = _term(self.frequency), _term(self.damping)
            body = f"({x}**2/{w}**2 + 2*{z}*{x}/{w} + 1)"
        else:
            raise BlockError(f"unknown controller factor kind {self.kind!r}")
        return body if self.kind.endswith("zero") else f"1/{body}"


def controller_transfer(
    gain: Coefficient, s_power: int = 0, factors: Sequence[ControllerFactor] = (), variable: str = "s"
) -> ExpressionTransfer:
    """gain * x^s_power * prod(factors): report 001's eq. (27) (K is kept with the actuator)."""
    terms = [_term(gain)] + [f.text(variable) for f in factors]
    if s_power > 0:
        terms.append(f"{variable}**{s_power}")
    elif s_power < 0:
        terms.append(f"1/{variable}**{-s_power}")
    return ExpressionTransfer("*".join(terms), variable)


class StateSpaceTransfer:
    """A SISO state space (A, B, C, D), kept as state space (`engine.model.state_space`):
    evaluated by a modal or Hessenberg decomposition (``response``), never multiplied out
    into polynomials; ``form``: its gain, zeros (transmission zeros) and poles (eigenvalues
    of A), equal roots cancelled."""

    exact = True
    rational_form = True
    parameters: tuple[str, ...] = ()

    def __init__(self, A: ArrayLike, B: ArrayLike, C: ArrayLike, D: ArrayLike = 0.0, source: str = "state space"):
        """Checked, decomposed and in pole-zero form at once: a fault is a `BlockError` naming ``source``."""
        self.matrices = checked(A, B, C, D, source)
        self.source = source
        try:
            self.response = Response(self.matrices)
            self.form = pole_zero_form(self.response)
        except BlockError as exc:
            raise BlockError(f"{source}: {exc}") from None

    @property
    def order(self) -> int:
        return self.matrices.order

    @property
    def text(self) -> str:
        return f"state space of order {self.order} ({self.source})"

    def compile(self, params: Mapping[str, float]) -> Compiled:
        return self.response

    def evaluate(
        self, x: NDArray, params: Mapping[str, float], with_dvar: bool = False, with_grad: bool = True
    ) -> Dual:
        value, slope = self.response(x)
        return Dual(value, {}, slope if with_dvar else None)

    @property
    def note(self) -> str | None:
        """One line when the model is ill-conditioned even balanced (`conditioning_note`)."""
        return conditioning_note(self.response, self.source)

    def realization(self) -> tuple[NDArray, NDArray, NDArray, NDArray]:
        """(A, B, C, D) balanced (the same system as given, `engine.model.state_space.balanced`)
        as n x n, n x 1, 1 x n and 1 x 1 arrays."""
        m = self.response.m
        return m.A, m.B[:, None], m.C[None, :], np.array([[m.D]])


def block_pole_zero(transfer: Transfer, params: Mapping[str, float]) -> PoleZero:
    """A rational block's pole-zero form: an expression's read factor by factor
    (`engine.model.factored`), a state space's from its realization."""
    if isinstance(transfer, StateSpaceTransfer):
        return transfer.form
    if isinstance(transfer, ExpressionTransfer):
        return pole_zero(transfer.expression, params)
    raise BlockError(f"{transfer.text}: a {type(transfer).__name__} has no pole-zero form")


class DelayTransfer:
    """exp(-x tau): a pure delay (frequency domain only)."""

    exact = True
    rational_form = False

    def __init__(self, tau: Coefficient):
        self.tau = tau
        self.parameters = (tau,) if isinstance(tau, str) else ()
        if not isinstance(tau, str) and not (np.isfinite(tau) and tau >= 0):
            raise BlockError(f"delay must be finite and >= 0, not {tau!r}")

    @property
    def text(self) -> str:
        return f"exp(-s*{_term(self.tau)})"

    def compile(self, params: Mapping[str, float]) -> Compiled:
        tau = float(params[self.tau]) if isinstance(self.tau, str) else float(self.tau)

        def evaluate(x: NDArray) -> tuple[NDArray, NDArray]:
            value = np.exp(-x * tau)
            return value, -tau * value

        return evaluate

    def evaluate(
        self, x: NDArray, params: Mapping[str, float], with_dvar: bool = False, with_grad: bool = True
    ) -> Dual:
        tau = float(params[self.tau]) if isinstance(self.tau, str) else float(self.tau)
        value = np.exp(-np.asarray(x, dtype=complex) * tau)
        grad = {self.tau: -x * value} if isinstance(self.tau, str) else {}
        return Dual(value, grad, -tau * value if with_dvar else None)


@dataclass(frozen=True)
class FrequencyTable:
    """A measured frequency response on increasing frequencies (rad/s)."""

    omega: NDArray[np.float64]
    response: NDArray[np.complex128]
    source: str = "table"

    @staticmethod
    def from_polar(
        frequencies: ArrayLike,
        magnitude: ArrayLike,
        phase_deg: ArrayLike,
        *,
        unit: Literal["hz", "rad/s"] = "rad/s",
        gain: float = 1.0,
        source: str = "table",
    ) -> FrequencyTable:
        """Magnitude (normalized, multiplied by ``gain``) and phase in degrees."""
        f, mag, phase = _columns(source, frequencies, magnitude, phase_deg)
        with np.errstate(over="ignore", invalid="ignore"):  # an overflow is reported as a non-finite row
            response = gain * mag * np.exp(1j * np.deg2rad(phase))
        return FrequencyTable._make(f, response, unit, source)

    @staticmethod
    def from_cartesian(
        frequencies: ArrayLike,
        real: ArrayLike,
        imag: ArrayLike,
        *,
        unit: Literal["hz", "rad/s"] = "rad/s",
        gain: float = 1.0,
        source: str = "table",
    ) -> FrequencyTable:
        """Real and imaginary parts, multiplied by ``gain``."""
        f, re, im = _columns(source, frequencies, real, imag)
        with np.errstate(over="ignore", invalid="ignore"):
            response = gain * (re + 1j * im)
        return FrequencyTable._make(f, response, unit, source)

    @staticmethod
    def _make(frequencies: ArrayLike, response: NDArray, unit: str, source: str) -> FrequencyTable:
        f = np.asarray(frequencies, dtype=float)
        if unit not in ("hz", "rad/s"):
            raise BlockError(f"{source}: frequency unit must be 'hz' or 'rad/s', not {unit!r}")
        if f.ndim != 1 or f.shape != np.shape(response) or f.size < 2:
            raise BlockError(f"{source}: needs at least two rows of equal length")
        with np.errstate(over="ignore"):
            omega = f * TWO_PI if unit == "hz" else f
        bad = np.flatnonzero(~np.isfinite(omega) | ~np.isfinite(response))
        if bad.size:
            raise BlockError(f"{source}: non-finite value in row {bad[0] + 1}")
        if np.any(f <= 0):
            raise BlockError(f"{source}: frequencies must be > 0 (row {np.flatnonzero(f <= 0)[0] + 1})")
        step = np.flatnonzero(np.diff(f) <= 0)
        if step.size:
            raise BlockError(f"{source}: frequencies must increase strictly (row {step[0] + 2})")
        if np.any(response == 0):
            raise BlockError(
                f"{source}: zero magnitude in row {np.flatnonzero(response == 0)[0] + 1} "
                "(log-magnitude interpolation needs |G| > 0)"
            )
        return FrequencyTable(omega, np.asarray(response, dtype=complex), source)

    def interpolate(self, omega: ArrayLike) -> NDArray[np.complex128]:
        """Linear in log frequency on log magnitude and unwrapped phase."""
        omega = np.asarray(omega, dtype=float)
        lo, hi = self.omega[0], self.omega[-1]
        tol = 1e-12 * hi
        outside = (omega < lo * (1 - 1e-12)) | (omega > hi + tol)
        if np.any(outside):
            w = omega[outside][0]
            raise ExtrapolationError(
                f"{self.source}: frequency {w:.6g} rad/s is outside the data "
                f"[{lo:.6g}, {hi:.6g}] rad/s; extrapolation is not allowed"
            )
        logw, logmag, phase = self._log_data
        at = np.log(np.clip(omega, lo, hi))
        return np.exp(np.interp(at, logw, logmag) + 1j * np.interp(at, logw, phase))

    @cached_property
    def _log_data(self) -> tuple[NDArray, NDArray, NDArray]:
        """log frequency, log magnitude and unwrapped phase of the data, computed once."""
        return np.log(self.omega), np.log(np.abs(self.response)), np.unwrap(np.angle(self.response))


def _columns(source: str, *columns: ArrayLike) -> list[NDArray[np.float64]]:
    """A table's columns as float arrays of one length (2 to `MAX_TABLE_ROWS` rows, finite)."""
    try:
        arrays = [np.asarray(c, dtype=float) for c in columns]
    except (TypeError, ValueError, OverflowError):
        raise BlockError(f"{source}: every column must be a list of numbers") from None
    lengths = sorted({a.size for a in arrays})
    if any(a.ndim != 1 for a in arrays) or len(lengths) > 1:
        raise BlockError(f"{source}: the columns must have one length, not {', '.join(map(str, lengths))}")
    if not 2 <= lengths[0] <= MAX_TABLE_ROWS:
        raise BlockError(f"{source}: a table has 2 to {MAX_TABLE_ROWS} rows, not {lengths[0]}")
    for a in arrays:
        bad = np.flatnonzero(~np.isfinite(a))
        if bad.size:
            raise BlockError(f"{source}: non-finite value in row {bad[0] + 1}")
    return arrays


_AT_GRID: Form[NDArray[np.complex128]] = Form("a table's response on a grid")


class TabulatedTransfer:
    """A block known only from a `FrequencyTable` (grid rule for margins)."""

    exact = False
    rational_form = False
    parameters: tuple[str, ...] = ()

    def __init__(self, table: FrequencyTable):
        self.table = table
        self._recent = Derived(4)  # the same few grids are asked for again and again (any thread)

    def response(self, omega: NDArray) -> NDArray[np.complex128]:
        """The interpolated response, remembered for the last few grids asked for."""
        w = np.asarray(omega, dtype=float)
        return self._recent.get(_AT_GRID, lambda: self.table.interpolate(omega), w.tobytes())

    @property
    def text(self) -> str:
        return f"table({self.table.source})"

    def evaluate(
        self, x: NDArray, params: Mapping[str, float], with_dvar: bool = False, with_grad: bool = True
    ) -> Dual:
        return Dual(self.response(np.asarray(x).imag), {}, None)


class FittedTableTransfer:
    """A table's rational fit in the table's place (`engine.margins.search.fitted_loop`): ``fit`` gives the
    response and its slope d/domega at any frequencies (rad/s), as exact as the fit is off the table."""

    exact = True
    rational_form = False
    parameters: tuple[str, ...] = ()

    def __init__(self, fit: Callable[[NDArray], tuple[NDArray, NDArray]], text: str):
        self.fit = fit
        self.text = text

    def compile(self, params: Mapping[str, float]) -> Compiled:
        def evaluate(x: NDArray) -> tuple[NDArray, NDArray]:
            value, slope = self.fit(np.asarray(x).imag)
            return value, slope / 1j  # d/ds on s = j omega

        return evaluate

    def evaluate(
        self, x: NDArray, params: Mapping[str, float], with_dvar: bool = False, with_grad: bool = True
    ) -> Dual:
        value, slope = self.compile(params)(x)
        return Dual(value, {}, slope if with_dvar else None)


Transfer = ExpressionTransfer | StateSpaceTransfer | DelayTransfer | TabulatedTransfer | FittedTableTransfer
