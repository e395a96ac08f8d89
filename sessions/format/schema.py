"""The session file format (JSON), modelled with pydantic.

Every model forbids unknown fields, so a misspelt key is an error that names
its path rather than something silently ignored.  `SCHEMA_VERSION` is the
version this code writes; older files are migrated (`sessions.format.migrations`).
"""

from __future__ import annotations

import math
from typing import Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, Field, model_validator

from engine.design.measure_kinds import MEASURE_KINDS

SCHEMA_VERSION = 2

from sessions.format.constraint_lines import ConstraintText
from sessions.format.limits import (  # noqa: F401
    MAX_BANDS,
    MAX_BLOCKS,
    MAX_BREAKS,
    MAX_CHANNELS,
    MAX_COEFFICIENTS,
    MAX_CONDITIONS,
    MAX_CONSTRAINTS,
    MAX_EQUALITIES,
    MAX_FACTORS,
    MAX_GRID_POINTS,
    MAX_JUNCTION_INPUTS,
    MAX_NYQUIST,
    MAX_OPTIONS,
    MAX_PARAMETERS,
    MAX_PORTS,
    MAX_RESPONSE_POINTS,
    MAX_SIGNALS,
    MAX_STATES,
    MAX_TABLE_ROWS,
    MAX_TARGETS,
    Coefficient,
    Lower,
    Number,
    Upper,
)
from sessions.format.limits import bounded as _bounded


class Strict(BaseModel):
    model_config = ConfigDict(extra="forbid")


class GridModel(Strict):
    """Frequency grid: ``points`` values from ``start`` to ``stop`` in ``unit``."""

    unit: Literal["rad/s", "hz"] = "rad/s"
    start: Annotated[Number, Field(gt=0)] | None = None
    stop: Annotated[Number, Field(gt=0)] | None = None
    points: Annotated[int, Field(ge=2, le=MAX_GRID_POINTS)] = 200
    spacing: Literal["log", "linear"] = "log"
    values: _bounded(list[Number], MAX_GRID_POINTS) | None = Field(
        default=None, description="explicit frequencies (e.g. a table's), instead of start/stop/points"
    )

    @model_validator(mode="after")
    def _increasing(self) -> GridModel:
        if self.values is not None:
            if self.start is not None or self.stop is not None:
                raise ValueError("give either values or start/stop, not both")
            if len(self.values) < 2 or any(b <= a for a, b in zip(self.values, self.values[1:])) or self.values[0] < 0:
                raise ValueError("values must be at least two increasing frequencies >= 0")
            return self
        if self.start is None or self.stop is None:
            raise ValueError("give start and stop (or values)")
        if self.stop <= self.start:
            raise ValueError("stop must be greater than start")
        return self


class FactorModel(Strict):
    kind: Literal["time_constant", "root", "second_order"]
    T: Coefficient = 0.0
    a: Coefficient = 0.0
    zeta: Coefficient = 0.5
    omega: Coefficient = 1.0

    @model_validator(mode="after")
    def _physical(self) -> FactorModel:
        if self.kind == "second_order":
            if isinstance(self.zeta, float) and not self.zeta > 0:
                raise ValueError("zeta: must be > 0")
            if isinstance(self.omega, float) and not self.omega > 0:
                raise ValueError("omega: must be > 0")
        return self


class TableModel(Strict):
    """Tabulated response, inline (``frequency`` and two columns) or in a CSV file
    next to the session (``csv`` with column names)."""

    unit: Literal["rad/s", "hz"] = "rad/s"
    form: Literal["polar", "db", "cartesian", "magnitude"] = Field(
        default="polar",
        description="polar: linear magnitude and phase in degrees; db: magnitude in dB and phase in degrees; "
        "cartesian: real and imaginary parts; magnitude: one value column (a PSD), phase 0",
    )
    gain: Number = 1.0
    frequency: _bounded(list[Number], MAX_TABLE_ROWS) | None = None
    first: _bounded(list[Number], MAX_TABLE_ROWS) | None = Field(default=None, description="magnitude, or real part")
    second: _bounded(list[Number], MAX_TABLE_ROWS) | None = Field(
        default=None, description="phase in degrees, or imaginary part"
    )
    csv: str | None = None
    columns: _bounded(list[str], 3) | None = Field(default=None, description="CSV columns: frequency, first, second")

    @model_validator(mode="after")
    def _one_source(self) -> TableModel:
        inline = self.frequency is not None
        if inline == (self.csv is not None):
            raise ValueError("give either frequency/first/second inline or csv with columns")
        two = self.form == "magnitude"
        if inline and (self.first is None or (self.second is None and not two)):
            raise ValueError("inline tables need frequency, first and second")
        lengths = [len(c) for c in (self.frequency, self.first, None if two else self.second) if c is not None]
        if inline and len(set(lengths)) > 1:
            raise ValueError(
                f"inline columns frequency, first{'' if two else ', second'} must have one length, "
                f"not {', '.join(map(str, lengths))}"
            )
        if self.csv is not None and (self.columns is None or len(self.columns) != (2 if two else 3)):
            raise ValueError("csv tables need three column names: frequency, first, second (two for form 'magnitude')")
        return self


class ExpressionBlock(Strict):
    kind: Literal["expression"]
    expression: str


class PolynomialBlock(Strict):
    kind: Literal["polynomial"]
    numerator: _bounded(list[Coefficient], MAX_COEFFICIENTS)
    denominator: _bounded(list[Coefficient], MAX_COEFFICIENTS)
    order: Literal["ascending", "descending"]


class FactoredBlock(Strict):
    kind: Literal["factored"]
    gain: Coefficient = 1.0
    s_power: Annotated[int, Field(ge=-64, le=64)] = 0
    zeros: _bounded(list[FactorModel], MAX_FACTORS) = []
    poles: _bounded(list[FactorModel], MAX_FACTORS) = []


class ControllerFactorModel(Strict):
    """Report 001, eq. (27): zero/pole (s/b + 1)^(+-1); complex (s^2/w^2 + 2 zeta s/w + 1)^(+-1)."""

    kind: Literal["zero", "pole", "complex_zero", "complex_pole"]
    b: Coefficient = 1.0
    damping: Coefficient = 0.5
    frequency: Coefficient = 1.0


class ControllerBlock(Strict):
    kind: Literal["controller"]
    gain: Coefficient
    s_power: Annotated[int, Field(ge=-64, le=64)] = 0
    factors: _bounded(list[ControllerFactorModel], MAX_FACTORS) = []


class TableBlock(Strict):
    kind: Literal["table"]
    table: TableModel


class DiscretizedBlock(Strict):
    """A continuous block (an expression in s, numbers only) discretized on the way in, for a
    condition in z: ``method`` zoh (exact; ``delay`` s, as whole and fractional samples), tustin
    (``prewarp`` rad/s, optional) or matched pole-zero."""

    kind: Literal["discretized"]
    expression: str
    method: Literal["zoh", "tustin", "matched"] = "zoh"
    delay: Annotated[Number, Field(ge=0)] = 0.0
    prewarp: Annotated[Number, Field(gt=0)] | None = None


class DelayBlock(Strict):
    kind: Literal["delay"]
    tau: Coefficient


class StateSpaceBlock(Strict):
    """A state space x' = A x + B u, y = C x + D u, kept as state space: ``A`` (its rows), ``B``,
    ``C`` and ``D`` inline, or ``file``: a .npz (arrays A, B, C and optionally D) or a .json (keys
    A, B, C, D) beside the session.  A SISO block: ``B`` the input column and ``C`` the output row
    (n numbers each), ``D`` a number; a block of m ports (its block's ``inputs`` and ``outputs``):
    ``B`` n rows of m numbers, ``C`` m rows of n numbers, ``D`` m rows of m numbers."""

    kind: Literal["state_space"]
    A: _bounded(list[_bounded(list[Number], MAX_STATES)], MAX_STATES) | None = Field(
        default=None, description="n rows of n numbers"
    )
    B: _bounded(list[Number], MAX_STATES) | _bounded(list[_bounded(list[Number], MAX_PORTS)], MAX_STATES) | None = (
        Field(default=None, description="the input column: n numbers (m ports: n rows of m numbers)")
    )
    C: _bounded(list[Number], MAX_STATES) | _bounded(list[_bounded(list[Number], MAX_STATES)], MAX_PORTS) | None = (
        Field(default=None, description="the output row: n numbers (m ports: m rows of n numbers)")
    )
    D: Number | _bounded(list[_bounded(list[Number], MAX_PORTS)], MAX_PORTS) | None = Field(
        default=None, description="the feedthrough (inline; null: 0; m ports: m rows of m numbers)"
    )
    file: str | None = Field(default=None, description="a .npz or .json file beside the session holding A, B, C, D")

    @model_validator(mode="after")
    def _one_source(self) -> StateSpaceBlock:
        given = [name for name in ("A", "B", "C", "D") if getattr(self, name) is not None]
        if (self.file is not None) == bool(given):
            raise ValueError("give either A, B, C (and D) inline or a file, not both")
        if self.file is None:
            missing = [name for name in ("A", "B", "C") if name not in given]
            if missing:
                raise ValueError(f"an inline state space needs A, B and C (missing {', '.join(missing)})")
            _check_square(self.A)
            if not self.ported:
                _check_siso_shapes(self)
        return self

    @property
    def ported(self) -> bool:
        """Inline matrices of several ports (B, C or D given as rows of numbers)."""
        return any(isinstance(x, list) and x and isinstance(x[0], list) for x in (self.B, self.C, self.D))


def _check_square(a: list[list[float]]) -> None:
    n = len(a)
    row = next((k for k, r in enumerate(a) if len(r) != n), None)
    if row is not None:
        raise ValueError(f"A must be square: it has {n} rows, and row {row + 1} has {len(a[row])} numbers")


def _check_siso_shapes(t: StateSpaceBlock) -> None:
    """B and C of n numbers each (n: A's size), with messages naming what differs."""
    n = len(t.A or [])
    for name, vector in (("B", t.B), ("C", t.C)):
        if vector is not None and len(vector) != n:
            raise ValueError(f"{name} has {len(vector)} numbers; with A {n} x {n} it must have {n}")


def _check_port_shapes(t: StateSpaceBlock, m: int) -> None:
    """B n x m, C m x n and D m x m (or null) for a block of m ports, naming the first row that differs."""
    n = len(t.A or [])
    for name, rows, width in (("B", t.B, m), ("C", t.C, n), ("D", t.D, m)):
        if name == "D" and (rows is None or rows == 0):
            continue
        wanted = f"{n if name == 'B' else m} rows of {width} numbers"
        if not isinstance(rows, list) or any(not isinstance(r, list) for r in rows):
            raise ValueError(f"transfer.{name} must be {wanted} (the block has {m} inputs and {m} outputs)")
        if len(rows) != (n if name == "B" else m):
            raise ValueError(f"transfer.{name} has {len(rows)} rows; it must be {wanted} (A is {n} x {n}, {m} ports)")
        row = next((k for k, r in enumerate(rows) if len(r) != width), None)
        if row is not None:
            raise ValueError(
                f"transfer.{name} row {row + 1} has {len(rows[row])} numbers; it must be {wanted} "
                f"(A is {n} x {n}, {m} ports)"
            )


Transfer = Annotated[
    ExpressionBlock
    | PolynomialBlock
    | FactoredBlock
    | TableBlock
    | DelayBlock
    | ControllerBlock
    | StateSpaceBlock
    | DiscretizedBlock,
    Field(discriminator="kind"),
]


class BlockModel(Strict):
    """A block: ``input`` and ``output`` signals, or, for a state space of m inputs and m outputs,
    ``inputs`` and ``outputs``: the signal each port reads or produces."""

    name: str
    input: str | None = None
    output: str | None = None
    inputs: _bounded(list[str], MAX_PORTS, 1) | None = Field(
        default=None, description="a state_space block's input ports: the signal each reads"
    )
    outputs: _bounded(list[str], MAX_PORTS, 1) | None = Field(
        default=None, description="a state_space block's output ports: the signal each produces"
    )
    transfer: Transfer

    @model_validator(mode="after")
    def _wired(self) -> BlockModel:
        for one, several in (("input", "inputs"), ("output", "outputs")):
            if (getattr(self, one) is None) == (getattr(self, several) is None):
                raise ValueError(f"give either {one} (a signal) or {several} (a state space's ports), not both")
        t = self.transfer
        if self.inputs is None or self.outputs is None:
            if t.kind == "state_space" and t.ported:
                raise ValueError(
                    "transfer: B, C or D as rows of numbers is a state space of several ports: name the signals "
                    "in inputs and outputs"
                )
            return self
        if t.kind != "state_space":
            raise ValueError(f"inputs and outputs (several ports) belong to a state_space block, not a {t.kind} block")
        if len(self.inputs) != len(self.outputs):
            raise ValueError(
                f"{len(self.inputs)} inputs and {len(self.outputs)} outputs: a block of several ports is square "
                "(as many outputs as inputs)"
            )
        if t.file is None:
            _check_port_shapes(t, len(self.inputs))
        return self

    @property
    def signals_in(self) -> list[str]:
        """The signals the block reads (one, or one per input port)."""
        return list(self.inputs) if self.inputs is not None else [self.input or ""]

    @property
    def signals_out(self) -> list[str]:
        """The signals the block produces (one, or one per output port)."""
        return list(self.outputs) if self.outputs is not None else [self.output or ""]


class JunctionModel(Strict):
    name: str
    output: str
    plus: _bounded(list[str], MAX_JUNCTION_INPUTS) = []
    minus: _bounded(list[str], MAX_JUNCTION_INPUTS) = []


class DiagramModel(Strict):
    format: Literal["diagram"]
    inputs: _bounded(list[str], MAX_SIGNALS) = []
    blocks: _bounded(list[BlockModel], MAX_BLOCKS)
    junctions: _bounded(list[JunctionModel], MAX_SIGNALS) = []


class MatrixEntry(Strict):
    row: Annotated[int, Field(ge=1)]
    col: Annotated[int, Field(ge=1)]
    expression: str


class MatrixModel(Strict):
    format: Literal["matrix"]
    signals: _bounded(list[str], MAX_SIGNALS)
    entries: _bounded(list[MatrixEntry], MAX_BLOCKS)
    forcing_row: Annotated[int, Field(ge=1)]
    forcing: str = "1"
    input_name: str = "theta"


class SubCompensatorModel(Strict):
    """One factor of a channel's compensator, coefficients in ascending powers
    (x_0, x_1, ... over y_0, y_1, ...) as the CIP listing reads them."""

    numerator: _bounded(list[Coefficient], MAX_COEFFICIENTS, 1)
    denominator: _bounded(list[Coefficient], MAX_COEFFICIENTS, 1)


class ChannelModel(Strict):
    """One channel of report 000's Figure 1: its uncompensated open-loop
    response theta_k/R times ``gain``, then a cascade of sub-compensators."""

    name: str
    response: Transfer
    gain: Number = 1.0
    compensators: _bounded(list[SubCompensatorModel], MAX_BLOCKS) = []
    hold_dc_gain: bool = Field(default=False, description="fix every constant term (the listing's KONT = 2)")


class ChannelsModel(Strict):
    """GH = sum over channels of response x gain x compensators.  Signals: the
    error ``e`` (break the loop there), the sum ``c``, and per channel
    ``NAME.theta`` and ``NAME.u``."""

    format: Literal["channels"]
    channels: _bounded(list[ChannelModel], MAX_CHANNELS, 1)


class CascadeModel(Strict):
    """Report 001's Figure 2: x2 = G1 (d - u), x1 = G2 x2, u = K Ga (H1 x1 + H2 x2).
    Give g2, or g1g2 (then G2 = G1G2/G1; two tables need the same frequencies).
    Signals: d (disturbance), e, x1, x2, u; break the loop at e."""

    format: Literal["cascade"]
    g1: Transfer
    g2: Transfer | None = None
    g1g2: Transfer | None = None
    ga: Transfer
    transducer_gain: Number = 1.0
    h1: Transfer | None = None
    h2: Transfer | None = None

    @model_validator(mode="after")
    def _one_g2(self) -> CascadeModel:
        if (self.g2 is None) == (self.g1g2 is None):
            raise ValueError("give either g2 or g1g2")
        if self.h1 is None and self.h2 is None:
            raise ValueError("give h1 and/or h2")
        return self


class ConditionModel(Strict):
    name: str
    variable: Literal["s", "w", "z"] = "s"
    sample_time: Annotated[Number, Field(gt=0, description="s; a loop in z only")] | None = None
    break_at: str
    breaks: _bounded(list[str], MAX_BREAKS) | None = Field(
        default=None, description="every loop break (signals) analyze reports; absent: [break_at]"
    )
    plant: Annotated[DiagramModel | MatrixModel | ChannelsModel | CascadeModel, Field(discriminator="format")]

    @model_validator(mode="after")
    def _breaks(self) -> ConditionModel:
        if self.breaks is not None and len(set(self.breaks)) != len(self.breaks):
            raise ValueError("breaks names a signal twice")
        return self

    @model_validator(mode="after")
    def _sampled(self) -> ConditionModel:
        if self.variable == "z" and self.sample_time is None:
            raise ValueError("a condition in z needs its sample_time (s)")
        if self.variable != "z" and self.sample_time is not None:
            raise ValueError(f"sample_time is for a condition in z, not in {self.variable}")
        if self.sample_time is not None and self.sample_time * MAX_NYQUIST < math.pi:
            raise ValueError(f"sample_time {self.sample_time:g} s: its Nyquist frequency pi/T is beyond 1e306 rad/s")
        return self


class ParameterModel(Strict):
    name: str
    value: Number | _bounded(list[Number], MAX_CONDITIONS)
    min: Lower | None = Field(default=None, description="null (or -inf): unbounded")
    max: Upper | None = Field(default=None, description="null (or inf): unbounded")
    free: bool = True
    sign: Literal["any", "positive", "negative"] = "any"

    @model_validator(mode="after")
    def _bounds(self) -> ParameterModel:
        if self.min is not None and self.max is not None and self.min > self.max:
            raise ValueError("min must not exceed max")
        for v in self.value if isinstance(self.value, list) else [self.value]:
            if (self.min is not None and v < self.min) or (self.max is not None and v > self.max):
                raise ValueError(
                    f"value {v!r} is outside [min, max] = [{self.min}, {self.max}] (the design "
                    "would be computed at the bound, not at this value)"
                )
        return self


class BandModel(Strict):
    low: Annotated[Number, Field(ge=0)] = 0.0
    high: Upper | None = Field(default=None, description="upper edge (the target's unit); null: no limit")
    desired: Number
    required: Number | None = Field(
        default=None,
        description="least acceptable value (most, for an at-most "
        "measure) when it differs from desired; slp constrains it and rewards "
        "improvement up to desired",
    )


class SegmentModel(Strict):
    time: Annotated[Number, Field(ge=0)] = 0.0
    step: Number = 0.0
    slope: Number = 0.0


class ResponseModel(Strict):
    """The time response a time-domain measure reads."""

    input: str
    output: str
    horizon: Annotated[Number, Field(gt=0)] = 10.0
    points: Annotated[int, Field(ge=10, le=MAX_RESPONSE_POINTS)] = 400
    profile: _bounded(list[SegmentModel], MAX_BANDS) = Field(
        default=[SegmentModel(step=1.0)], description="steps and ramps at the input (e.g. a wind profile)"
    )
    psd: str | None = Field(default=None, description="mean_square: shaping filter F(s), PSD = |F(jw)|^2")
    reference: Number = 1.0
    settling_band: Annotated[float, Field(gt=0, lt=1)] = 0.05


class PointModel(Strict):
    real: Number
    imag: Number = 0.0
    mode: Literal["push", "pull"] = "push"


MeasureName = Literal[tuple(MEASURE_KINDS)]  # the measure kinds, from their one table


class TargetModel(Strict):
    # "break" is a Python keyword: the field is at_break, read and written as "break"
    model_config = ConfigDict(extra="forbid", validate_by_name=True, validate_by_alias=True, serialize_by_alias=True)

    measure: MeasureName
    condition: str | None = None
    at_break: str | None = Field(
        default=None,
        alias="break",
        description="the loop break the measure is read at: one of its conditions' breaks (null: their break_at)",
    )
    bands: _bounded(list[BandModel], MAX_BANDS)
    weight: Number = 1.0
    scale: Number = 1.0
    points: _bounded(list[PointModel], MAX_BANDS) = []
    detect_low: Annotated[Number, Field(ge=0)] = 0.0
    detect_high: Upper | None = Field(default=None, description="null: no upper limit")
    unit: Literal["rad/s", "hz"] = Field(default="rad/s", description="unit of band edges and detect_low/high")
    sense: Literal["at_least", "at_most"] | None = Field(
        default=None, description="null: the measure's own (at most for peaks, times, errors; at least otherwise)"
    )
    requirement: bool = Field(default=True, description="false: only in the objective, never a requirement")
    response: ResponseModel | None = Field(default=None, description="for time-domain measures")


class ObjectiveModel(Strict):
    kind: str
    options: Annotated[dict[str, Number | str], Field(max_length=MAX_OPTIONS)] = {}
    tables: Annotated[dict[str, TableModel], Field(max_length=MAX_OPTIONS)] = Field(
        default={}, description="e.g. noise_psd (form 'magnitude')"
    )
    data: dict[str, Any] = Field(
        default={},
        description="structured inputs: for kind 'dae' the matrices A, B, E, F, x0, horizon, steps, bounds, Q, R",
    )


class EqualityModel(Strict):
    """sum of coefficient * parameter = value; a key is a parameter's name, or
    name[condition] for a parameter with a value per condition."""

    terms: Annotated[dict[str, Number], Field(min_length=1, max_length=MAX_PARAMETERS)]
    value: Number = 0.0


class ProblemModel(Strict):
    grid: GridModel
    conditions: _bounded(list[ConditionModel], MAX_CONDITIONS) = Field(
        default=[], description="at least one, except for a 'dae' objective"
    )
    parameters: _bounded(list[ParameterModel], MAX_PARAMETERS) = []
    targets: _bounded(list[TargetModel], MAX_TARGETS) = []
    objective: ObjectiveModel | None = None
    equalities: _bounded(list[EqualityModel], MAX_EQUALITIES) = Field(
        default=[], description="linear equalities between parameters (slp)"
    )
    constraints: _bounded(list[ConstraintText], MAX_CONSTRAINTS) = Field(
        default=[],
        description="linear inequalities between parameters, one a line: 'T1 >= 4*T2', "
        "'K + 2*T1[cruise] <= 10' (docs/session-format.md)",
    )
    noise_factor: float = Field(
        default=100.0,
        gt=1.0,
        le=1e12,
        description="a design note flags a compensator whose high-frequency gain is more than this "
        "times its gain at the crossover (it amplifies sensor noise)",
    )


class AlgorithmModel(Strict):
    name: str
    settings: dict[str, Any] = {}


class ProvenanceModel(Strict):
    loopcraft_version: str
    created: str
    modified: str


class SweepModel(Strict):
    """A sweep's results (`loopcraft sweep`); `version` is this section's own format version."""

    version: Literal[2]
    kind: Literal["starts", "vary", "tolerance"]
    created: str
    algorithm: str
    settings: dict[str, Any] = {}
    workers: int = 0
    cancelled: bool = False
    runs: list[dict[str, Any]] = Field(
        default=[],
        description="one per run: index, label, start, parameters, "
        "ranking, status, reason, measures, meets_requirements, worker, attempts",
    )
    failed: list[int] = []
    excluded: dict[str, int] = Field(
        default={}, description="tolerance sweeps: reason -> how many samples it left out of the statistics"
    )
    retried: dict[str, list[str]] = Field(default={}, description="run index -> the workers it was started on")
    optima: list[dict[str, Any]] = Field(
        default=[], description="parameters, ranking, count, meets_requirements, best_run, runs"
    )
    worst_case: list[dict[str, Any]] = Field(default=[], description="tolerance sweeps: per measure row")


class RunStageModel(Strict):
    """A run before the current one: the parameters it started from (values and bounds),
    its algorithm and its records (up to the iteration its design was taken from)."""

    kind: Literal["run"]
    parameters: list[ParameterModel]
    algorithm: AlgorithmModel
    records: list[dict[str, Any]] = []


class HandChangeModel(Strict):
    name: str
    before: Number | list[Number]
    after: Number | list[Number]


class HandStageModel(Strict):
    """Parameter values changed by hand (the shaping table, `loopcraft set` and `tune`)
    between runs: each one's value before and after."""

    kind: Literal["hand"]
    changes: list[HandChangeModel]


EarlierStage = Annotated[RunStageModel | HandStageModel, Field(discriminator="kind")]


class SessionModel(Strict):
    """A whole session: the problem, the algorithm, what it did, and notes."""

    schema_version: Literal[2]
    provenance: ProvenanceModel
    notes: str = ""
    problem: ProblemModel
    algorithm: AlgorithmModel
    records: list[dict[str, Any]] = []
    current_iteration: Annotated[int, Field(ge=0)] = 0
    state: dict[str, Any] | None = Field(default=None, description="the algorithm state after the current iteration")
    sweeps: list[SweepModel] = Field(default=[], description="results of `loopcraft sweep`, oldest first")
    earlier: list[EarlierStage] = Field(
        default=[], description="the runs and hand moves before the current run, oldest first"
    )
