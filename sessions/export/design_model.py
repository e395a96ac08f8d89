"""What every export reads: one design (an iteration's parameter values) as plain
numbers per flight condition, entry by entry of the compiled interconnection.

Each entry of a condition's network (``x_row += G x_col``: a block, one signal
of a junction, a matrix entry) becomes an `ExportEntry`: its rational form
(descending coefficients, and gain/zeros/poles taken factor by factor), a pure
delay, or a tabulated block's table (its frequencies and response: python-control's
``frd``, MATLAB's), or on request its AAA fit with the fit's residual, refused where the
fit has right-half-plane roots outside the table's band (`sessions.export.tables`).  Entries that depend on a parameter are the
compensators.  Signal names are also given as identifiers (``ident``) for
tools whose signal names are parsed (python-control's ``sys.signal``).
"""

from __future__ import annotations

import re
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from engine.errors import EngineError
from engine.model.bilinear import z_transfer
from engine.model.blocks import DelayTransfer, ExpressionTransfer, StateSpaceTransfer, TabulatedTransfer
from engine.model.factored import pole_zero
from engine.model.network import Network
from engine.model.ports.state_space_ports import StateSpaceChannel
from sessions.errors import SessionError
from sessions.export.tables import fit_fields, table_fields
from sessions.store import Session


@dataclass(frozen=True)
class ExportEntry:
    """One entry: ``output += transfer * input``.  ``kind``: "rational", "delay", "state_space"
    (``matrices``) or "fitted" (a table's AAA fit: ``residual``, ``degree``); ``num``/``den`` descending."""

    label: str
    input: str
    output: str
    kind: str
    text: str
    compensator: bool
    num: tuple[float, ...] = ()
    den: tuple[float, ...] = ()
    gain: float = 1.0
    zeros: tuple[complex, ...] = ()
    poles: tuple[complex, ...] = ()
    delay: float = 0.0
    residual: float | None = None
    degree: int = 0
    omega: tuple[float, ...] = ()  # a table's frequencies (rad/s) and its response there
    response: tuple[complex, ...] = ()
    sample_time: float | None = None  # an entry of a condition in z: num/den, zeros and poles in z
    matrices: tuple = ()  # a state-space block's (A rows, B, C, D) as given (kind "state_space")

    @property
    def constant(self) -> float | None:
        """The value of a constant gain (a junction's sign), else None."""
        if self.kind == "rational" and len(self.num) == 1 and len(self.den) == 1:
            return self.num[0] / self.den[0]
        return None

    @property
    def degrees(self) -> tuple[int, int]:
        """(numerator degree, denominator degree) of a rational or fitted entry, leading zeros dropped."""
        zeros, poles = (len(np.trim_zeros(np.asarray(v, dtype=float), "f")) - 1 for v in (self.num, self.den))
        return zeros, poles


@dataclass(frozen=True)
class ExportCondition:
    """One flight condition of the design: its network's signals and entries."""

    name: str
    variable: str
    break_at: str
    signals: tuple[str, ...]
    inputs: tuple[str, ...]
    entries: tuple[ExportEntry, ...]
    values: dict[str, float]
    network: Network
    chain: tuple[int, ...] | None = None  # a unity loop: every entry on the one chain, L = sign * their product
    sample_time: float | None = None  # a condition in z (its entries in z)
    breaks: tuple[str, ...] = ()  # every loop break when the condition names several (else none)

    def ident(self, signal: str) -> str:
        """The signal's name as an identifier, unique within the condition."""
        return identifiers(self.signals)[signal]


@dataclass(frozen=True)
class Design:
    """The design of one iteration: every condition, the parameters as the session names them."""

    source: str
    iteration: int
    parameters: dict[str, float | list[float]]
    conditions: tuple[ExportCondition, ...]


def iteration_parameters(session: Session, iteration: int | None) -> tuple[int, dict | None]:
    """(K, the named parameters of iteration K) -- None for K = 0 (the session's start);
    K defaults to the current iteration; outside 0..current a `SessionError` naming --iteration."""
    current = session.model.current_iteration
    k = current if iteration is None else iteration
    if not 0 <= k <= current:
        raise SessionError(f"--iteration: {k} is outside 0..{current}")
    return k, (session.model.records[k - 1].get("parameters") if k else None)


def design(session: Session, iteration: int | None = None, fit: bool = False) -> Design:
    """The design of an iteration (default: the last) as exportable numbers; a table as
    its table, or (``fit``) as its rational fit, checked (`sessions.export.tables`)."""
    k, named = iteration_parameters(session, iteration)
    problem = session.problem
    if not problem.conditions:
        raise SessionError(
            f"{session.path or 'session'}: it has no flight conditions (a 'dae' problem): there is no loop to export"
        )
    conditions = []
    for c, condition in enumerate(problem.conditions):
        values = problem.condition_values(c, named=named)
        network = condition.network
        entries = tuple(_entry(network, e, values, f"condition {condition.name!r}", fit) for e in network.entries)
        conditions.append(
            ExportCondition(
                condition.name,
                network.variable if network.sample_time is None else "z",
                condition.break_at,
                network.signals,
                network.inputs,
                entries,
                values,
                network,
                unity_chain(entries, network.inputs, condition.break_at),
                network.sample_time,
                condition.every_break if condition.several_breaks else (),
            )
        )
    return Design(
        str(session.path or "session"), k, problem.named() if named is None else dict(named), tuple(conditions)
    )


def unity_chain(entries: tuple[ExportEntry, ...], inputs: tuple[str, ...], break_at: str) -> tuple[int, ...] | None:
    """The entries of a unity loop in the order the signal goes round from ``break_at``
    (L = -(their product)); None unless every other entry is a constant fed by an input
    (the reference's +1 into the junction): any other diagram needs interconnect."""
    outside = {n for n, e in enumerate(entries) if e.input in inputs}
    if any(entries[n].constant is None for n in outside):
        return None
    chain, signal = [], break_at
    for _ in entries:
        readers = [n for n, e in enumerate(entries) if e.input == signal and n not in outside]
        if len(readers) != 1 or readers[0] in chain:
            return None
        chain.append(readers[0])
        signal = entries[readers[0]].output
        if signal == break_at:
            break
    covered = set(chain) | outside
    return tuple(chain) if signal == break_at and covered == set(range(len(entries))) else None


def _entry(network: Network, e, values: dict[str, float], where: str, fit: bool) -> ExportEntry:
    """One entry's exportable numbers; a failure is a `SessionError` naming the condition
    and the entry (numpy's "array must not contain infs or NaNs" said neither)."""
    try:
        return _numbers(network, e, values, fit)
    except (EngineError, ValueError, ArithmeticError) as exc:  # LinAlgError is a ValueError
        raise SessionError(f"{where}, {e.label}: cannot be exported: {not_finite(exc)}") from None


def not_finite(exc: Exception) -> str:
    """An error of numpy or scipy in words: a non-finite array says that the numbers
    overflow (inf or NaN), not what numpy calls them."""
    text = str(exc)
    if "infs or NaNs" in text or "overflow" in text:
        return "its numbers are not finite at these parameter values (a coefficient overflows to inf or NaN)"
    return text


def _numbers(network: Network, e, values: dict[str, float], fit: bool) -> ExportEntry:
    common = dict(
        label=e.label,
        input=network.signals[e.col],
        output=network.signals[e.row],
        compensator=bool(e.transfer.parameters),
    )
    transfer = e.transfer
    if isinstance(transfer, ExpressionTransfer) and network.sample_time is not None:
        transfer = z_transfer(transfer)  # exported as typed, in z
        common["sample_time"] = network.sample_time
    if isinstance(transfer, ExpressionTransfer):
        r = transfer.rational(values)
        form = pole_zero(transfer.expression, values)
        return ExportEntry(
            kind="rational",
            text=transfer.text,
            num=tuple(r.num.tolist()),
            den=tuple(r.den.tolist()),
            gain=float(form.gain),
            zeros=tuple(form.zeros.tolist()),
            poles=tuple(form.poles.tolist()),
            **common,
        )
    if isinstance(transfer, StateSpaceChannel):  # its channels apart would each carry a copy of its states
        raise SessionError(
            "a state space of several ports is not exported yet (its channels written apart would each hold a "
            "copy of its states: hidden modes in every closed loop)"
        )
    if isinstance(transfer, StateSpaceTransfer):
        if network.sample_time is not None:
            common["sample_time"] = network.sample_time
        m, form = transfer.matrices, transfer.form
        return ExportEntry(
            kind="state_space",
            text=transfer.text,
            gain=float(form.gain),
            zeros=tuple(form.zeros.tolist()),
            poles=tuple(form.poles.tolist()),
            matrices=(tuple(map(tuple, m.A.tolist())), tuple(m.B.tolist()), tuple(m.C.tolist()), m.D),
            **common,
        )
    if isinstance(transfer, DelayTransfer):
        tau = values[transfer.tau] if isinstance(transfer.tau, str) else float(transfer.tau)
        return ExportEntry(kind="delay", text=transfer.text, delay=float(tau), **common)
    if isinstance(transfer, TabulatedTransfer):
        return ExportEntry(**(fit_fields(transfer) if fit else table_fields(transfer)), **common)
    raise SessionError(f"it is a {type(transfer).__name__} entry")


def identifiers(names: tuple[str, ...]) -> dict[str, str]:
    """Each name as a Python/MATLAB identifier (non-word characters as _), unique."""
    out: dict[str, str] = {}
    used: set[str] = set()
    for name in names:
        base = re.sub(r"\W", "_", name) or "signal"
        base = base if base[0].isalpha() else "s_" + base
        candidate, k = base, 2
        while candidate in used:
            candidate, k = f"{base}_{k}", k + 1
        used.add(candidate)
        out[name] = candidate
    return out


def loop_input(condition: ExportCondition, at: str | None = None) -> str:
    """The identifier of the injected loop signal replacing the uses of the break ``at``
    (None: ``break_at``)."""
    taken = set(identifiers(condition.signals).values())
    name = condition.ident(condition.break_at if at is None else at) + "_loop"
    while name in taken:
        name += "_"
    return name


def refuse_improper(condition: ExportCondition, why: str) -> None:
    """A `SessionError` naming the condition's first improper block (a rational or fitted entry
    with more zeros than poles); ``why``: what the target tool would do with it."""
    for e in condition.entries:
        zeros, poles = e.degrees
        if e.kind in ("rational", "fitted") and zeros > poles:
            raise SessionError(
                f"condition {condition.name!r}: block {e.label!r} is improper (numerator degree {zeros} > "
                f"denominator degree {poles}): {why}"
            )


def rows(condition: ExportCondition) -> list[tuple[str, list[ExportEntry]]]:
    """The entries grouped by the signal they define, in the network's order."""
    grouped: dict[str, list[ExportEntry]] = {}
    for entry in condition.entries:
        grouped.setdefault(entry.output, []).append(entry)
    return list(grouped.items())


def is_junction(entries: list[ExportEntry]) -> bool:
    """Several entries of +-1 into one signal: a summing junction."""
    return len(entries) > 1 and all(e.constant in (1.0, -1.0) for e in entries)


def w_to_z(num: tuple[float, ...], den: tuple[float, ...]) -> tuple[list[float], list[float]]:
    """H(w) -> H(z) by w = (z - 1)/(z + 1) (the session's unscaled w-plane), descending,
    normalized to a monic denominator."""
    n = max(len(num), len(den)) - 1

    def substitute(coefficients: tuple[float, ...]) -> NDArray:
        total = np.zeros(1)
        for k, c in enumerate(coefficients[::-1]):  # c multiplies w^k
            term = np.poly1d([1.0, -1.0]) ** k * np.poly1d([1.0, 1.0]) ** (n - k)
            total = np.polyadd(total, c * term.coeffs)
        return np.trim_zeros(np.atleast_1d(total), "f") if np.any(total) else np.zeros(1)

    zn, zd = substitute(num), substitute(den)
    return (zn / zd[0]).tolist(), (zd / zd[0]).tolist()


def fitted_entries(design_: Design) -> list[ExportEntry]:
    """The entries that are fits of tables (their residuals go in the exports' comments)."""
    return [e for c in design_.conditions for e in c.entries if e.kind == "fitted"]
