"""Turn a validated `SessionModel` into the engine's `Problem`.

Engine errors (an expression that does not parse, an unknown signal) are
re-raised as `SessionError` prefixed with the JSON path of what caused them.
CSV tables and state-space files are read here, relative to the session's
folder: a file outside it (an absolute path, ``..``, a symlink leading out)
is refused unless allowed (``allow_outside_tables``); only regular files, at
most MAX_TABLE_BYTES and MAX_TABLE_ROWS, read with a bounded read; messages
quote no more of a file than the offending cell.
"""

from __future__ import annotations

import csv
import io
import math
from collections.abc import Iterator
from contextlib import contextmanager
from contextvars import ContextVar
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from engine.design.measure_kinds import EVERY_BREAK
from engine.design.problem import (
    FREQUENCY_MEASURES,
    BandValue,
    Condition,
    Grid,
    LinearEquality,
    Objective,
    Parameter,
    Point,
    Problem,
    Target,
    TimeResponse,
)
from engine.errors import EngineError, shortened
from engine.model.blocks import (
    ControllerFactor,
    DelayTransfer,
    ExpressionTransfer,
    Factor,
    FrequencyTable,
    StateSpaceTransfer,
    TabulatedTransfer,
    controller_transfer,
    factored_transfer,
    polynomial_transfer,
)
from engine.model.discretize import discretized_text
from engine.model.network import Block, Junction, Network, PortedBlock, block_diagram, matrix_format, sampled_network
from engine.model.ports.state_space_ports import PortedStateSpace
from sessions.errors import SessionError
from sessions.format.constraint_lines import build_inequalities, check_start, engine_error
from sessions.format.limits import MAX_TABLE_ROWS
from sessions.format.reading import decoded, read_regular, resolved
from sessions.format.schema import (
    CascadeModel,
    ChannelsModel,
    ConditionModel,
    EqualityModel,
    GridModel,
    ParameterModel,
    ProblemModel,
    StateSpaceBlock,
    TableModel,
    TargetModel,
)
from sessions.format.state_space_files import read_matrices

MAX_TABLE_BYTES = 20 * 2**20  # a CSV table's size (its rows: MAX_TABLE_ROWS, sessions.format.limits)
SHOWN_CELL = 40  # characters of an offending cell quoted in a message


class OutsideTable(SessionError):
    """A table outside the session's folder was refused; ``name`` is what its ``csv`` says
    (the app asks the user, then loads again with the tables allowed)."""

    def __init__(self, message: str, name: str):
        super().__init__(message)
        self.name = name


_OUTSIDE_ALLOWED: ContextVar[bool] = ContextVar("loopcraft_outside_tables_allowed", default=False)


@contextmanager
def outside_tables_allowed(allowed: bool = True) -> Iterator[None]:
    """Within it, tables outside a session's folder are read (``allowed``) or refused
    (the command line's --allow-outside-tables; `build_problem`'s keyword sets it too)."""
    token = _OUTSIDE_ALLOWED.set(allowed)
    try:
        yield
    finally:
        _OUTSIDE_ALLOWED.reset(token)


def build_problem(
    model: ProblemModel,
    folder: Path,
    *,
    allow_outside_tables: bool | None = None,
    start_checked: bool = True,
    conditions: tuple[Condition, ...] | None = None,
) -> Problem:
    """The engine problem of a session; errors name their JSON path.  Tables outside
    ``folder`` are refused unless ``allow_outside_tables`` (None: as the enclosing
    `outside_tables_allowed` says; refused by default).  ``start_checked`` False: the start is
    not checked against the constraints (a change under way, checked as a whole at its end).
    ``conditions``: the model's conditions built already (an edit of parameter values alone
    keeps its loops, their tables read and the forms kept on them: `engine.derived`)."""
    if allow_outside_tables is None:
        return _build_problem(model, folder, start_checked, conditions)
    with outside_tables_allowed(allow_outside_tables):
        return _build_problem(model, folder, start_checked, conditions)


def _build_problem(
    model: ProblemModel, folder: Path, start_checked: bool, built: tuple[Condition, ...] | None = None
) -> Problem:
    conditions = (
        tuple(_condition(c, f"problem.conditions[{i}]", folder) for i, c in enumerate(model.conditions))
        if built is None
        else built
    )
    parameters = tuple(
        _parameter(p, f"problem.parameters[{i}]", len(conditions)) for i, p in enumerate(model.parameters)
    )
    parameters = _hold_dc_gains(model, parameters)
    targets = tuple(_target(t) for t in model.targets)
    for k, t in enumerate(model.targets):
        _check_response(t, f"problem.targets[{k}].response", conditions)
        _check_break(t, f"problem.targets[{k}].break", conditions)
    grid = _grid(model.grid)
    _check_sampled(model, conditions, grid)
    objective = (
        None
        if model.objective is None
        else Objective(
            model.objective.kind,
            dict(model.objective.options),
            {
                name: frequency_table(t, f"problem.objective.tables.{name}", folder)
                for name, t in model.objective.tables.items()
            },
            dict(model.objective.data),
        )
    )
    names = [c.name for c in model.conditions]
    equalities = tuple(_equality(e, f"problem.equalities[{i}]", names) for i, e in enumerate(model.equalities))
    inequalities = build_inequalities(model)
    try:
        problem = Problem(
            conditions, parameters, targets, grid, objective, equalities, inequalities, model.noise_factor
        )
    except EngineError as exc:
        raise engine_error(exc) from None
    if start_checked:
        check_start(problem)
    return problem


def _check_break(t: TargetModel, path: str, conditions: tuple[Condition, ...]) -> None:
    """A target's break is a break of every condition it is read in, and its measure is read on an
    open loop (a frequency measure: a time response or a pole is the whole closed loop's); else a
    `SessionError` naming ``path``."""
    if t.at_break is None:
        return
    if t.measure not in FREQUENCY_MEASURES:
        raise SessionError(f"{path}: a {t.measure} target is read on the whole closed loop, not at a loop break")
    if t.measure in EVERY_BREAK:
        raise SessionError(f"{path}: a {t.measure} target is read at every break of its conditions at once, not at one")
    for c in conditions:
        if t.condition in (None, c.name) and t.at_break not in c.every_break:
            raise SessionError(
                f"{path}: {t.at_break!r} is not a break of condition {c.name!r} (its breaks: {', '.join(c.every_break)})"
            )


def _check_response(t: TargetModel, path: str, conditions: tuple[Condition, ...]) -> None:
    """A time target's response names an input and a signal of every condition it is
    evaluated in, and a mean square its input's PSD; else a `SessionError` naming ``path``."""
    if t.response is None:
        return
    if t.measure == "mean_square" and t.response.psd is None:
        raise SessionError(f"{path}.psd: a mean_square target needs the input's PSD as a shaping filter F(s)")
    for c in conditions:
        if t.condition not in (None, c.name):
            continue
        if t.response.input not in c.network.inputs:
            raise SessionError(
                f"{path}.input: {t.response.input!r} is not an input of condition {c.name!r} "
                f"(inputs: {', '.join(c.network.inputs) or 'none'})"
            )
        if t.response.output not in c.network.signals:
            raise SessionError(
                f"{path}.output: {t.response.output!r} is not a signal of condition {c.name!r} "
                f"(signals: {', '.join(c.network.signals)})"
            )


def _check_sampled(model: ProblemModel, conditions: tuple[Condition, ...], grid: Grid) -> None:
    """A condition in z is read below its Nyquist frequency: the grid ends below pi/T; its time
    responses are at its samples, and a mean square (a continuous PSD) is not one of its targets;
    else a `SessionError` naming the path."""
    for i, c in enumerate(conditions):
        T = c.network.sample_time
        if T is None:
            continue
        if grid.omega[-1] >= math.pi / T:
            raise SessionError(
                f"problem.grid: it reaches {grid.omega[-1]:.6g} rad/s, at or above the Nyquist frequency pi/T = "
                f"{math.pi / T:.6g} rad/s of condition {c.name!r} (problem.conditions[{i}].sample_time {T:g} s): "
                "end the grid below it"
            )
        for k, t in enumerate(model.targets):
            if t.condition in (None, c.name) and t.measure == "mean_square":
                raise SessionError(
                    f"problem.targets[{k}].measure: mean_square is not evaluated on condition {c.name!r}, a loop "
                    "in z (its noise PSD is a continuous shaping filter)"
                )


def _hold_dc_gains(model: ProblemModel, parameters: tuple[Parameter, ...]) -> tuple[Parameter, ...]:
    """Channels with ``hold_dc_gain``: the parameters that are constant terms stay fixed."""
    held = {
        coefficient
        for condition in model.conditions
        if condition.plant.format == "channels"
        for channel in condition.plant.channels
        if channel.hold_dc_gain
        for sub in channel.compensators
        for coefficient in (sub.numerator[0], sub.denominator[0])
        if isinstance(coefficient, str)
    }
    return tuple(replace(p, free=False) if p.name in held else p for p in parameters)


def _grid(g: GridModel) -> Grid:
    with np.errstate(all="ignore"):  # frequencies out of range are refused below, not warned about
        if g.values is not None:
            values = np.array(g.values, dtype=float)
        elif g.spacing == "log":
            values = np.geomspace(g.start, g.stop, g.points)
        else:
            values = np.linspace(g.start, g.stop, g.points)
        values = values * (2 * np.pi) if g.unit == "hz" else values
    if not np.all(np.isfinite(values)):
        raise SessionError("problem.grid: the frequencies overflow (a stop below 1e300 rad/s, please)")
    return Grid(values, g.unit)


def _condition(c: ConditionModel, path: str, folder: Path) -> Condition:
    plant = c.plant
    try:
        if plant.format == "matrix":
            entries = {(e.row, e.col): e.expression for e in plant.entries}
            network = matrix_format(
                plant.signals, entries, plant.forcing_row, plant.forcing, plant.input_name, c.variable
            )
        elif plant.format == "channels":
            network = _channels(plant, path, folder, c.variable)
        elif plant.format == "cascade":
            network = _cascade(plant, f"{path}.plant", folder, c.variable)
        else:
            blocks = [
                _block(b, f"{path}.plant.blocks[{i}]", folder, c.variable, c.sample_time)
                for i, b in enumerate(plant.blocks)
            ]
            junctions = [
                Junction(j.name, j.output, tuple((1.0, s) for s in j.plus) + tuple((-1.0, s) for s in j.minus))
                for j in plant.junctions
            ]
            network = block_diagram(blocks, junctions, plant.inputs, c.variable)
        network.signal(c.break_at)
        _check_breaks(network, c.breaks or [], f"{path}.breaks")
        if c.sample_time is not None:
            network = sampled_network(network, c.sample_time)
    except SessionError:
        raise
    except EngineError as exc:
        raise SessionError(f"{path}: {exc}") from None
    return Condition(c.name, network, c.break_at, tuple(c.breaks) if c.breaks else (c.break_at,))


def _check_breaks(network: Network, breaks: list[str], path: str) -> None:
    """Each of a condition's ``breaks`` a signal of its diagram that lies on a loop, or an error naming it."""
    for k, name in enumerate(breaks):
        if name not in network.index:
            raise SessionError(f"{path}[{k}]: unknown signal {name!r}; signals are {', '.join(network.signals)}")
        if not network.on_a_loop(name):
            raise SessionError(
                f"{path}[{k}]: signal {name!r} lies on no loop of the diagram: breaking it opens no loop "
                "(the loop seen there is 0)"
            )


def _channels(plant: ChannelsModel, path: str, folder: Path, variable: str) -> Network:
    """Report 000's Figure 1 as a block diagram: e -> response x gain -> cascade -> sum c; e = r - c."""
    blocks, outputs = [], []
    for k, ch in enumerate(plant.channels):
        where = f"{path}.plant.channels[{k}]"
        theta = f"{ch.name}.theta"
        blocks.append(
            Block(
                f"{ch.name}.response",
                "e",
                theta,
                _transfer(ch.response, f"{where}.response", folder, variable),
                ch.name,
            )
        )
        signal = theta
        if ch.gain != 1.0:
            blocks.append(
                Block(
                    f"{ch.name}.gain", signal, f"{ch.name}.scaled", ExpressionTransfer(repr(ch.gain), variable), ch.name
                )
            )
            signal = f"{ch.name}.scaled"
        for i, sub in enumerate(ch.compensators, start=1):
            try:
                transfer = polynomial_transfer(sub.numerator, sub.denominator, "ascending", variable)
            except EngineError as exc:
                raise SessionError(f"{where}.compensators[{i - 1}]: {exc}") from None
            out = f"{ch.name}.u" if i == len(ch.compensators) else f"{ch.name}.{i}"
            blocks.append(Block(f"{ch.name}.{i}", signal, out, transfer, ch.name))
            signal = out
        if not ch.compensators:
            blocks.append(
                Block(f"{ch.name}.direct", signal, f"{ch.name}.u", ExpressionTransfer("1", variable), ch.name)
            )
        outputs.append(f"{ch.name}.u")
    junctions = [
        Junction("sum", "c", tuple((1.0, u) for u in outputs)),
        Junction("error", "e", ((1.0, "r"), (-1.0, "c"))),
    ]
    return block_diagram(blocks, junctions, ["r"], variable)


def _cascade(plant: CascadeModel, path: str, folder: Path, variable: str) -> Network:
    """Report 001's Figure 2 as a block diagram with blocks G1, G2, Ga, H1, H2."""

    def make(name: str):
        return _transfer(getattr(plant, name), f"{path}.{name}", folder, variable)

    g1 = make("g1")
    g2 = make("g2") if plant.g2 is not None else _ratio(make("g1g2"), g1, f"{path}.g1g2", variable)
    ga = _times(make("ga"), plant.transducer_gain, variable)
    blocks = [Block("G1", "e", "x2", g1), Block("G2", "x2", "x1", g2), Block("Ga", "c", "u", ga)]
    terms = []
    for name, source in (("h1", "x1"), ("h2", "x2")):
        if getattr(plant, name) is not None:
            blocks.append(Block(name.upper(), source, f"c{name[1]}", make(name)))
            terms.append((1.0, f"c{name[1]}"))
    junctions = [Junction("controllers", "c", tuple(terms)), Junction("error", "e", ((1.0, "d"), (-1.0, "u")))]
    return block_diagram(blocks, junctions, ["d"], variable)


def _ratio(g1g2, g1, path: str, variable: str):
    """G2 = G1G2 / G1: of two tables on the same frequencies, or of two expressions."""
    if isinstance(g1g2, TabulatedTransfer) and isinstance(g1, TabulatedTransfer):
        a, b = g1g2.table, g1.table
        if a.omega.shape != b.omega.shape or not np.allclose(a.omega, b.omega, rtol=1e-12):
            raise SessionError(f"{path}: G1G2 and G1 tables need the same frequencies to give G2 = G1G2/G1")
        with np.errstate(all="ignore"):
            ratio = a.response / b.response
        if not np.all(np.isfinite(ratio)):
            raise SessionError(
                f"{path}: G2 = G1G2/G1 is not finite at every frequency (G1 is zero, or the "
                "quotient overflows, somewhere)"
            )
        return TabulatedTransfer(FrequencyTable(a.omega, ratio, f"{a.source} / {b.source}"))
    if isinstance(g1g2, ExpressionTransfer) and isinstance(g1, ExpressionTransfer):
        return ExpressionTransfer(f"({g1g2.text})/({g1.text})", variable)
    raise SessionError(f"{path}: give g2 when G1 and G1G2 are not both tables or both expressions")


def _times(transfer, gain: float, variable: str):
    """A transfer times a constant gain (the transducer gain K with the actuator)."""
    if gain == 1.0:
        return transfer
    if isinstance(transfer, TabulatedTransfer):
        t = transfer.table
        with np.errstate(all="ignore"):
            response = gain * t.response
        if not np.all(np.isfinite(response)) or not np.all(response != 0):
            raise SessionError(f"{t.source}: times the transducer gain {gain:g}, the table is not finite and nonzero")
        return TabulatedTransfer(FrequencyTable(t.omega, response, t.source))
    if isinstance(transfer, ExpressionTransfer):
        return ExpressionTransfer(f"{gain!r}*({transfer.text})", variable)
    if isinstance(transfer, StateSpaceTransfer):
        m = transfer.matrices
        return StateSpaceTransfer(m.A, m.B, gain * m.C, gain * m.D, transfer.source)
    raise SessionError("the transducer gain applies to a table, an expression or a state space")


def _block(b, path: str, folder: Path, variable: str, sample_time: float | None = None) -> Block | PortedBlock:
    if b.inputs is not None:
        return _ported_block(b, path, folder)
    return Block(b.name, b.input, b.output, _transfer(b.transfer, f"{path}.transfer", folder, variable, sample_time))


def _ported_block(b, path: str, folder: Path) -> PortedBlock:
    """A state space of several ports (inline or from its file), its ports wired to the named signals;
    a fault names the block's JSON path (a file of other shapes: `transfer.file`)."""
    try:
        matrices = PortedStateSpace(*_state_space_matrices(b.transfer, f"{path}.transfer", folder))
        return PortedBlock(b.name, tuple(b.inputs), tuple(b.outputs), matrices)
    except EngineError as exc:
        raise SessionError(f"{path}: {exc}") from None


def _transfer(t, path: str, folder: Path, variable: str, sample_time: float | None = None):
    try:
        if t.kind == "discretized":
            if sample_time is None:
                raise SessionError(f"{path}: a discretized block belongs to a condition in z (with its sample_time)")
            transfer = ExpressionTransfer(
                discretized_text(t.expression, sample_time, t.method, t.delay, t.prewarp), "z"
            )
        elif t.kind == "expression":
            transfer = ExpressionTransfer(t.expression, variable)
        elif t.kind == "polynomial":
            transfer = polynomial_transfer(t.numerator, t.denominator, t.order, variable)
        elif t.kind == "factored":
            transfer = factored_transfer(
                t.gain,
                t.s_power,
                [Factor(**f.model_dump()) for f in t.zeros],
                [Factor(**f.model_dump()) for f in t.poles],
                variable,
            )
        elif t.kind == "delay":
            transfer = DelayTransfer(t.tau)
        elif t.kind == "controller":
            transfer = controller_transfer(
                t.gain, t.s_power, [ControllerFactor(**f.model_dump()) for f in t.factors], variable
            )
        elif t.kind == "state_space":
            transfer = state_space_transfer(t, path, folder)
        else:
            transfer = TabulatedTransfer(frequency_table(t.table, f"{path}.table", folder))
    except SessionError:
        raise
    except EngineError as exc:
        raise SessionError(f"{path}: {exc}") from None
    return transfer


def state_space_transfer(t: StateSpaceBlock, path: str, folder: Path) -> StateSpaceTransfer:
    """A state-space block from its inline matrices or its file (beside the session, as a
    table's CSV is: `table_path`); errors name the JSON path and the file."""
    return StateSpaceTransfer(*_state_space_matrices(t, path, folder))


def _state_space_matrices(t: StateSpaceBlock, path: str, folder: Path) -> tuple[Any, Any, Any, Any, str]:
    """A, B, C, D and their source ("inline" or the file's name) of a state-space block of any ports."""
    if t.file is None:
        return t.A, t.B, t.C, 0.0 if t.D is None else t.D, "inline"
    m = read_matrices(table_path(folder, t.file, path, field="file"), f"{path}.file")
    return m["A"], m["B"], m["C"], m["D"], t.file


def frequency_table(t: TableModel, path: str, folder: Path) -> FrequencyTable:
    if t.csv is not None:
        f, first, second = read_csv(table_path(folder, t.csv, path), t.columns, path)
    else:
        f, first, second = t.frequency, t.first, t.second
    if t.form == "magnitude":
        second = [0.0] * len(first)
    if t.form == "db":
        first = [10.0 ** (v / 20.0) for v in first]
    elif t.form in ("polar", "magnitude"):
        _check_linear_magnitudes(first, t, path)
    make = FrequencyTable.from_cartesian if t.form == "cartesian" else FrequencyTable.from_polar
    try:
        return make(f, first, second, unit=t.unit, gain=t.gain, source=path)
    except EngineError as exc:
        raise SessionError(str(exc)) from None


def _check_linear_magnitudes(values: list[float], t: TableModel, path: str) -> None:
    """A linear magnitude is >= 0: a negative one is refused, naming its row and column
    (a column in dB read as linear gave a gain margin of 193 dB)."""
    row = next((k for k, v in enumerate(values) if v < 0), None)
    if row is None:
        return
    column = t.columns[1] if t.csv is not None and t.columns else "first"
    raise SessionError(
        f"{path}: row {row + 1} of column {column!r}: magnitude {values[row]:g} is negative; a linear magnitude "
        "is >= 0 (a magnitude in dB is the form 'db')"
    )


def table_path(folder: Path, name: str, path: str, allow_outside: bool | None = None, field: str = "csv") -> Path:
    """The file a table's ``csv`` (a state space's ``file``: ``field``) names, relative to the
    session's ``folder``; one outside it (absolute, or leaving it by .. or a symlink) is refused
    unless ``allow_outside`` (None: as the enclosing `outside_tables_allowed` says)."""
    if "\0" in name:  # no file system takes it (pathlib raised a bare ValueError)
        raise SessionError(f"{path}.{field}: {name!r} is not a file name (it holds a NUL character)")
    allowed = _OUTSIDE_ALLOWED.get() if allow_outside is None else allow_outside
    file = Path(folder) / name
    if allowed:
        return file
    try:
        base, real = resolved(Path(folder)), resolved(file)
    except SessionError as exc:
        raise SessionError(f"{path}.{field}: {exc}") from None
    if Path(name).is_absolute() or not real.is_relative_to(base):
        what = "tables are" if field == "csv" else "state-space files are"
        raise OutsideTable(
            f"{path}.{field}: {name!r} is outside the session's folder {base}: {what} read from "
            "the session's folder or below (--allow-outside-tables allows others)",
            name,
        )
    return real  # what was checked is what is opened


def read_csv(file: Path, columns: list[str], path: str) -> tuple[list[float], ...]:
    """The named columns of a CSV file (lines starting with # skipped); errors name line
    and column.  Only a regular file of at most MAX_TABLE_BYTES and MAX_TABLE_ROWS rows."""
    numbered = [
        (n, line)
        for n, line in enumerate(io.StringIO(bounded_text(file, path), newline=""), start=1)
        if not line.startswith("#")
    ]
    if len(numbered) - 1 > MAX_TABLE_ROWS:
        raise SessionError(
            f"{path}.csv: {file.name} has {len(numbered) - 1} rows; a table has at most {MAX_TABLE_ROWS}"
        )
    reader = csv.DictReader(line for _, line in numbered)
    try:
        rows, header = list(reader), reader.fieldnames or []
    except csv.Error as exc:
        line = numbered[min(max(reader.reader.line_num, 1), len(numbered)) - 1][0]
        raise SessionError(f"{file.name}: line {line}: not CSV ({exc})") from None
    missing = [c for c in columns if c not in header]
    if missing:
        raise SessionError(f"{path}.columns: {file.name} has no column(s) {', '.join(missing)}")
    return _columns(file, columns, numbered, rows)


def bounded_text(file: Path, path: str) -> str:
    """The text of a regular file of at most MAX_TABLE_BYTES (never more is read;
    `sessions.format.reading`), a BOM dropped; errors are prefixed with ``path``."""
    try:
        return decoded(read_regular(file, MAX_TABLE_BYTES)[0], file)
    except SessionError as exc:
        raise SessionError(f"{path}.csv: {exc}") from None


def _columns(file: Path, columns: list[str], numbered: list, rows: list[dict]) -> tuple[list[float], ...]:
    out: list[list[float]] = [[] for _ in columns]
    for (n, _), row in zip(numbered[1:], rows):
        for k, name in enumerate(columns):
            try:
                out[k].append(float(row[name]))
            except (TypeError, ValueError):
                raise SessionError(
                    f"{file.name}: line {n}, column {name!r}: not a number: {_shown(row[name])}"
                ) from None
    return tuple(out) if len(out) == 3 else (out[0], out[1], [])


def _shown(cell: str | None) -> str:
    """An offending cell as quoted in a message: at most SHOWN_CELL characters of it."""
    if cell is None:
        return "(missing)"
    return repr(shortened(cell, SHOWN_CELL + 3))


def _parameter(p: ParameterModel, path: str, conditions: int) -> Parameter:
    value = tuple(p.value) if isinstance(p.value, list) else p.value
    if isinstance(value, tuple) and len(value) != conditions:
        raise SessionError(f"{path}.value: {len(value)} values for {conditions} conditions")
    return Parameter(
        p.name, value, -np.inf if p.min is None else p.min, np.inf if p.max is None else p.max, p.free, p.sign
    )


def _target(t: TargetModel) -> Target:
    """Band edges and detection limits are converted to rad/s."""
    scale = 2 * np.pi if t.unit == "hz" else 1.0

    def upper(x: float | None) -> float:
        return np.inf if x is None else x * scale

    response = (
        None
        if t.response is None
        else TimeResponse(
            t.response.input,
            t.response.output,
            t.response.horizon,
            t.response.points,
            tuple((seg.time, seg.step, seg.slope) for seg in t.response.profile),
            t.response.psd,
            t.response.reference,
            t.response.settling_band,
        )
    )
    return Target(
        t.measure,
        tuple(BandValue(b.low * scale, upper(b.high), b.desired, b.required) for b in t.bands),
        t.condition,
        t.weight,
        t.scale,
        tuple(Point(complex(q.real, q.imag), q.mode) for q in t.points),
        t.detect_low * scale,
        upper(t.detect_high),
        t.sense,
        t.requirement,
        response,
        t.at_break,
    )


def _equality(e: EqualityModel, path: str, conditions: list[str]) -> LinearEquality:
    """Terms 'name' (shared) or 'name[condition]' (a condition's name or its index)."""
    terms = []
    for key, coefficient in e.terms.items():
        name, _, rest = key.partition("[")
        condition = None
        if rest:
            label = rest.rstrip("]")
            if label in conditions:
                condition = conditions.index(label)
            elif label.isdigit() and int(label) < len(conditions):
                condition = int(label)
            else:
                raise SessionError(f"{path}.terms.{key}: no condition {label!r} (conditions: {', '.join(conditions)})")
        terms.append((name.strip(), condition, coefficient))
    return LinearEquality(tuple(terms), e.value)
