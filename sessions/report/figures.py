"""The design report's figures, drawn with matplotlib's Agg backend into PNG bytes.

matplotlib is imported inside the functions (the report alone needs it, and
the command line starts without it).  Each figure shows the final design
(solid) beside the initial one (dashed) of one flight condition: Bode with
the margins and the targets marked, Nyquist with -1 and the targets' circles around it
(each margin target in its distance form |1 + GH|, report 000), Nichols, |S| and |T|
with the Ms and Mt ceilings, the root locus, and the closed-loop step response with its
overshoot, settling and rise-time bounds; and the convergence history.  A requirement's
line is green where the design meets it, red where it misses it.
"""

from __future__ import annotations

import io
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from engine.analysis import LoopCurve
from engine.closed_loop.root_locus import PoleZeroMap, RootLocus
from engine.closed_loop.time_response import StepMeasures
from engine.design.problem import Target
from engine.stepping.protocol import MeasureRow
from sessions.format.save_file import printable

SIZE = (7.0, 4.2)  # inches; at DPI, 700 x 420 pixels
DPI = 100


def _style(curve: LoopCurve) -> str:
    """A curve's line style by its role: a reference (the initial design) dashed."""
    return "--" if curve.role == "reference" else "-"


def _figure(rows: int = 1):
    """A figure on the Agg canvas (no pyplot, no global backend switch)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(SIZE[0], SIZE[1] * (1.5 if rows > 1 else 1.0)), dpi=DPI)
    FigureCanvasAgg(fig)
    return fig, [fig.add_subplot(rows, 1, k + 1) for k in range(rows)]


def _png(fig) -> bytes:
    """The figure's PNG; every text drawn as it is written (any string a JSON file can
    hold: a lone surrogate as its escape, a '$' never read as mathtext)."""
    from matplotlib.text import Text

    for text in fig.findobj(Text):
        text.set_parse_math(False)
        text.set_text(printable(text.get_text()))
    buffer = io.BytesIO()
    fig.tight_layout()
    fig.savefig(buffer, format="png", dpi=DPI)
    return buffer.getvalue()


def _plain_log_ticks(*axes) -> None:
    """Log-axis tick labels as plain numbers ('0.01', '100'): the default ones are
    mathtext, which `_png` turns off for every text."""
    from matplotlib.ticker import FuncFormatter, NullFormatter

    for ax in axes:
        ax.xaxis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
        ax.xaxis.set_minor_formatter(NullFormatter())


def _db(gh: np.ndarray) -> np.ndarray:
    with np.errstate(all="ignore"):
        return 20 * np.log10(np.abs(gh))


def _desired(rows: Sequence[MeasureRow], kind: str) -> MeasureRow | None:
    """The first row of a measure kind that has a desired value (None: no such target)."""
    return next((r for r in rows if r.kind == kind and r.desired is not None and np.isfinite(r.desired)), None)


def _requirement_style(row: MeasureRow) -> dict:
    """A requirement's line: red where the design misses it, green where it meets it."""
    return {"color": "tab:green" if row.satisfied else "tab:red", "ls": "--", "lw": 1.0}


@dataclass(frozen=True)
class Requirement:
    """A requirement's line on a figure's ``panel`` ("magnitude", "phase", "nichols"): from (x0, y0)
    to (x1, y1) in its data units (frequencies in the figure's unit), its legend label, met or not."""

    panel: str
    x: tuple[float, float]
    y: tuple[float, float]
    label: str
    met: bool


SPAN = 2.0  # a margin's requirement is drawn from f/SPAN to f*SPAN about its crossing
NICHOLS_SPAN = (15.0, 3.0)  # deg, dB: the half-widths of a margin's requirement on the Nichols chart
PEAK_KINDS = ("modal_peak_db",)


def _sense(row: MeasureRow) -> str:
    return ">=" if row.at_least else "<="


def _judged(rows: Sequence[MeasureRow], kind: str) -> list[MeasureRow]:
    """The rows of a kind with a desired value and a crossing (each drawn at its own crossing)."""
    return [
        r
        for r in rows
        if r.kind == kind
        and r.desired is not None
        and np.isfinite(r.desired)
        and r.frequency is not None
        and np.isfinite(r.frequency)
        and r.frequency > 0
    ]


def bode_requirements(
    curve: LoopCurve | None, rows: Sequence[MeasureRow], targets: Sequence[Target] = (), scale: float = 1.0
) -> list[Requirement]:
    """The requirements a Bode plot draws: each gain-margin row at |GH| = -GM about its phase crossover and
    each phase-margin row at -180 + PM on ``curve``'s branch about its gain crossover (its name, sense and
    value in the legend); the crossover bound; each modal-peak band's ceiling over that band only."""
    found = [
        Requirement(
            "magnitude",
            (r.frequency / scale / SPAN, r.frequency / scale * SPAN),
            (-r.desired,) * 2,
            f"{r.name} {_sense(r)} {r.desired:g} dB",
            r.satisfied,
        )
        for r in _judged(rows, "gain_margin_db")
    ]
    for r in _judged(rows, "phase_margin_deg") if curve is not None else ():
        level = curve.on_branch(-180.0 + r.desired, r.frequency)
        span = (r.frequency / scale / SPAN, r.frequency / scale * SPAN)
        found.append(Requirement("phase", span, (level, level), f"{r.name} {_sense(r)} {r.desired:g} deg", r.satisfied))
    wc = _desired(rows, "crossover_frequency")
    if wc is not None:
        x = wc.desired / scale
        found.append(
            Requirement(
                "magnitude", (x, x), (np.nan, np.nan), f"crossover {_sense(wc)} {wc.desired:g} rad/s", wc.satisfied
            )
        )
    for target in (t for t in targets if t.measure in PEAK_KINDS):
        for band in target.bands:
            inside = [
                r
                for r in rows
                if r.kind == target.measure and r.frequency is not None and band.low <= r.frequency <= band.high
            ]
            level = next((r.desired for r in inside if r.desired is not None), band.requirement)  # as judged
            names = "/".join(r.name for r in inside) or "modal peak"
            high = band.high if np.isfinite(band.high) else (curve.omega[-1] if curve is not None else band.low * 10)
            found.append(
                Requirement(
                    "magnitude",
                    (max(band.low, 1e-300) / scale, high / scale),
                    (level, level),
                    f"{names} <= {level:g} dB in {band.low / scale:g}-{high / scale:g}",
                    all(r.satisfied for r in inside),
                )
            )
    return found


def nichols_requirements(curve: LoopCurve | None, rows: Sequence[MeasureRow]) -> list[Requirement]:
    """The margins' requirements on a Nichols chart, on ``curve``'s branch: each gain margin's level -GM dB
    about -180 deg, each phase margin's -180 + PM deg about 0 dB."""
    if curve is None:
        return []
    dx, dy = NICHOLS_SPAN
    found = []
    for r in _judged(rows, "gain_margin_db"):
        x = curve.on_branch(-180.0, r.frequency)
        found.append(
            Requirement(
                "nichols", (x - dx, x + dx), (-r.desired,) * 2, f"{r.name} {_sense(r)} {r.desired:g} dB", r.satisfied
            )
        )
    for r in _judged(rows, "phase_margin_deg"):
        x = curve.on_branch(-180.0 + r.desired, r.frequency)
        found.append(Requirement("nichols", (x, x), (-dy, dy), f"{r.name} {_sense(r)} {r.desired:g} deg", r.satisfied))
    return found


def _draw(axes: dict, requirements: Sequence[Requirement]) -> None:
    for q in requirements:
        style = {"color": "tab:green" if q.met else "tab:red", "ls": "--", "lw": 1.2, "label": q.label}
        ax = axes[q.panel]
        if np.isnan(q.y[0]):  # a frequency bound: the whole height
            ax.axvline(q.x[0], **style)
        else:
            ax.plot(q.x, q.y, **style)


def _current(curves: list[LoopCurve]) -> LoopCurve | None:
    """The curve the requirements are judged on: the final design's (the last drawn)."""
    return curves[-1] if curves else None


def bode(
    curves: list[LoopCurve], unit: str, title: str, rows: Sequence[MeasureRow] = (), targets: Sequence[Target] = ()
) -> bytes:
    """Magnitude and phase against frequency; gain margins (at phase crossovers) and
    phase margins (at gain crossovers, on the curve's branch) of the curves that carry them, marked;
    the requirements of ``rows`` (a tableau's) and ``targets``' modal-peak bands drawn."""
    fig, (mag, phase) = _figure(2)
    scale = 2 * np.pi if unit == "hz" else 1.0
    for c in curves:
        mag.semilogx(c.omega / scale, _db(c.gh), _style(c), label=c.label)
        phase.semilogx(c.omega / scale, c.phase_deg, _style(c), label=c.label)
        for m in c.margins.listed("G") if c.margins else ():  # a delay's periodic family: its few
            if m.frequency > 0 and m.gain_db is not None and np.isfinite(m.gain_db):
                mag.plot([m.frequency / scale] * 2, [0.0, -m.gain_db], "r-", lw=1.5)
                mag.annotate(f"GM {m.gain_db:.3g} dB", (m.frequency / scale, -m.gain_db), fontsize=7)
        for m in c.margins.phase if c.margins else ():
            on_curve = c.on_branch(float(np.degrees(np.angle(m.gh))), m.frequency)
            mag.plot([m.frequency / scale], [0.0], "go", ms=4)
            phase.plot([m.frequency / scale], [on_curve], "go", ms=4)
            phase.annotate(f"PM {m.phase_deg:.3g} deg", (m.frequency / scale, on_curve), fontsize=7)
    mag.axhline(0.0, color="k", lw=0.5)
    low, high = phase.get_ylim()
    for k in np.arange(np.ceil((low + 180) / 360), np.floor((high + 180) / 360) + 1) * 360 - 180:
        phase.axhline(k, color="k", lw=0.5, ls=":")  # -180 deg on every branch in view
    _draw({"magnitude": mag, "phase": phase}, bode_requirements(_current(curves), rows, targets, scale))
    _plain_log_ticks(mag, phase)
    mag.set_ylabel("magnitude (dB)")
    phase.set_ylabel("phase (deg)")
    phase.set_xlabel(f"frequency ({unit})")
    mag.set_title(title)
    mag.legend(fontsize=7)
    phase.legend(fontsize=7)
    return _png(fig)


def sensitivity(curves: list[LoopCurve], unit: str, title: str, rows: Sequence[MeasureRow] = ()) -> bytes:
    """|S| = 1/|1 + GH| and |T| = |GH/(1 + GH)| in dB, with the Ms and Mt ceilings."""
    fig, (ax,) = _figure()
    scale = 2 * np.pi if unit == "hz" else 1.0
    for c in curves:
        with np.errstate(all="ignore"):
            s, t = 1 / (1 + c.gh), c.gh / (1 + c.gh)
        line = ax.semilogx(c.omega / scale, _db(s), _style(c), label=f"|S| {c.label}")[0]
        ax.semilogx(c.omega / scale, _db(t), _style(c), color=line.get_color(), alpha=0.5, label=f"|T| {c.label}")
    for kind, name in (("sensitivity_peak", "Ms"), ("complementary_sensitivity_peak", "Mt")):
        row = _desired(rows, kind)
        if row is not None and row.desired > 0:
            ax.axhline(20 * np.log10(row.desired), **_requirement_style(row), label=f"{name} <= {row.desired:g}")
    ax.axhline(0.0, color="k", lw=0.5)
    _plain_log_ticks(ax)
    ax.set_xlabel(f"frequency ({unit})")
    ax.set_ylabel("magnitude (dB)")
    ax.set_title(title)
    ax.legend(fontsize=7)
    return _png(fig)


def locus(found: RootLocus, pole_zero: PoleZeroMap, title: str, sample_time: float | None = None) -> bytes:
    """Root locus branches in the loop gain (``found``), the open-loop poles (x) and zeros
    (o) of ``pole_zero``, the design's closed-loop poles (*); a sampled loop's in z, about the
    unit circle."""
    fig, (ax,) = _figure()
    branches = np.asarray(found.branches)
    for j in range(branches.shape[1]):
        column = branches[:, j]
        keep = np.isfinite(column)
        ax.plot(
            column.real[keep], column.imag[keep], "-", color="tab:blue", lw=0.8, label="branches" if j == 0 else None
        )
    current = np.asarray(found.current)
    ax.plot(current.real, current.imag, "*", color="tab:red", ms=8, label="design (k = 1)")
    poles, zeros = np.asarray(pole_zero.poles), np.asarray(pole_zero.zeros)
    ax.plot(poles.real, poles.imag, "x", color="k", label="open-loop poles")
    if zeros.size:
        ax.plot(zeros.real, zeros.imag, "o", mfc="none", color="k", label="open-loop zeros")
    finite = np.concatenate([current, poles])
    reach = np.abs(finite[np.isfinite(finite)]).max(initial=1.0) * 1.5
    if sample_time is None:
        ax.set_xlim(-reach, reach * 0.3)
        ax.axvline(0.0, color="k", lw=0.5)
    else:  # in z: the unit circle, the stability boundary
        theta = np.linspace(0, 2 * np.pi, 200)
        ax.plot(np.cos(theta), np.sin(theta), "k:", lw=0.6, label=f"|z| = 1 (T = {sample_time:g} s)")
        reach = max(reach, 1.5)
        ax.set_xlim(-reach, reach)
        ax.set_aspect("equal", adjustable="box")  # the limits are square: the box adjusts, no limit is ignored
    ax.set_ylim(-reach, reach)
    ax.set_xlabel("Re")
    ax.set_ylabel("Im")
    ax.set_title(title)
    ax.legend(fontsize=7)
    return _png(fig)


def nyquist(curves: list[LoopCurve], circles: list[tuple[str, float]], title: str) -> bytes:
    """GH in the complex plane (and its mirror image), -1, and circles of the given
    radii around -1 (the targets' distances |1 + GH|); clipped to |GH| <= 4."""
    fig, (ax,) = _figure()
    theta = np.linspace(0, 2 * np.pi, 200)
    for c in curves:
        gh = np.where(np.abs(c.gh) > 4.0, np.nan, c.gh)
        line = ax.plot(gh.real, gh.imag, _style(c), label=c.label)[0]
        ax.plot(gh.real, -gh.imag, _style(c), color=line.get_color(), alpha=0.35)
    ax.plot(np.cos(theta), np.sin(theta), "k:", lw=0.6)
    for label, radius in circles:
        ax.plot(-1 + radius * np.cos(theta), radius * np.sin(theta), "--", lw=0.8, label=label)
    ax.plot([-1.0], [0.0], "r+", ms=12, mew=2)
    ax.set_xlim(-4, 4)
    ax.set_ylim(-3, 3)
    ax.set_aspect("equal", adjustable="box")
    ax.set_xlabel("real GH")
    ax.set_ylabel("imag GH")
    ax.set_title(title)
    ax.legend(fontsize=7)
    return _png(fig)


def nichols(curves: list[LoopCurve], title: str, rows: Sequence[MeasureRow] = ()) -> bytes:
    """Magnitude (dB) against phase (deg), with the critical point (-180 deg, 0 dB) on the final
    curve's branch at its crossover and the margins' requirements of ``rows`` (`nichols_requirements`)."""
    fig, (ax,) = _figure()
    for c in curves:
        ax.plot(c.phase_deg, _db(c.gh), _style(c), label=c.label)
    current = _current(curves)
    crossings = [m.frequency for m in current.margins.phase] if current is not None and current.margins else []
    critical = current.on_branch(-180.0, crossings[0]) if crossings else -180.0
    ax.plot([critical], [0.0], "r+", ms=12, mew=2)
    _draw({"nichols": ax}, nichols_requirements(current, rows))
    ax.set_xlabel("phase (deg)")
    ax.set_ylabel("magnitude (dB)")
    ax.set_title(title)
    ax.legend(fontsize=7)
    return _png(fig)


def step(
    traces: list[tuple], what: str, title: str, rows: Sequence[MeasureRow] = (), measures: StepMeasures | None = None
) -> bytes:
    """Step responses (t, y, label, line style), with the requirements of ``rows``: the
    overshoot ceiling, the settling band from the settling-time target on, the rise-time
    bound (about the final value of ``measures``, the design's)."""
    fig, (ax,) = _figure()
    for t, y, label, style in traces:
        ax.plot(t, y, style, label=label)
    final = measures.final if measures is not None else None
    if final:
        overshoot, settle, rise = (_desired(rows, k) for k in ("overshoot_percent", "settling_time", "rise_time"))
        if overshoot is not None:
            level = final * (1 + overshoot.desired / 100)
            ax.axhline(level, **_requirement_style(overshoot), label=f"overshoot <= {overshoot.desired:g} %")
        if settle is not None:
            end = traces[-1][0][-1]
            for edge in (0.95, 1.05):
                ax.plot([settle.desired, max(end, settle.desired)], [final * edge] * 2, **_requirement_style(settle))
            ax.axvline(settle.desired, **_requirement_style(settle), label=f"settled (5 %) by {settle.desired:g} s")
        if rise is not None:
            ax.axvline(rise.desired, **_requirement_style(rise), label=f"rise time <= {rise.desired:g} s")
    ax.set_xlabel("time (s)")
    ax.set_ylabel(what)
    ax.set_title(title)
    ax.legend(fontsize=7)
    return _png(fig)


def convergence(iterations: list[int], values: list[float], label: str) -> bytes:
    """The presenter's convergence value against the iteration."""
    fig, (ax,) = _figure()
    ax.plot(iterations, values, "o-")
    ax.set_xlabel("iteration")
    ax.set_ylabel(label or "value")
    ax.set_title("convergence")
    ax.grid(True, lw=0.3)
    return _png(fig)


def histograms(rows: list[dict]) -> bytes:
    """A tolerance study's histograms, one per measure and flight condition (three to a
    row of panels), each with its desired value: green when every sample meets it, red
    otherwise."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    columns = min(3, len(rows))
    lines = -(-len(rows) // columns)
    fig = Figure(figsize=(SIZE[0], 2.2 * lines + 0.4), dpi=DPI)
    FigureCanvasAgg(fig)
    for k, row in enumerate(rows):
        ax = fig.add_subplot(lines, columns, k + 1)
        edges = row["histogram"]["edges"]
        if edges:
            ax.stairs(row["histogram"]["counts"], edges, fill=True, alpha=0.6)
            _desired_line(ax, row, (edges[0], edges[-1]))
        ax.set_title(f"{row['name']} at {row['condition']}", fontsize=8)
        ax.tick_params(labelsize=7)
    return _png(fig)


def _desired_line(ax, row: dict, span: tuple[float, float]) -> None:
    """The desired value: a line within the samples' span, else its value written on the
    side where it lies (the histogram keeps its scale)."""
    desired = None if row.get("desired") is None else float(row["desired"])
    if desired is None or np.isnan(desired):
        return
    color = "green" if row["unmet_samples"] == 0 else "red"
    ax.set_xlim(*span)
    if span[0] <= desired <= span[1]:
        ax.axvline(desired, color=color, lw=1.2)
        return
    right = desired > span[1]
    text = f"desired {desired:.4g} " + ("->" if right else "<-")
    place = {"ha": "right" if right else "left", "color": color, "fontsize": 7, "transform": ax.transAxes}
    ax.text(0.98 if right else 0.02, 0.92, text, **place)
