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

import numpy as np

from engine.analysis import LoopCurve
from engine.closed_loop.root_locus import PoleZeroMap, RootLocus
from engine.closed_loop.time_response import StepMeasures
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


def _phase(gh: np.ndarray) -> np.ndarray:
    return np.degrees(np.unwrap(np.angle(gh)))


def _desired(rows: Sequence[MeasureRow], kind: str) -> MeasureRow | None:
    """The first row of a measure kind that has a desired value (None: no such target)."""
    return next((r for r in rows if r.kind == kind and r.desired is not None and np.isfinite(r.desired)), None)


def _requirement_style(row: MeasureRow) -> dict:
    """A requirement's line: red where the design misses it, green where it meets it."""
    return {"color": "tab:green" if row.satisfied else "tab:red", "ls": "--", "lw": 1.0}


def _bode_requirements(mag, phase, rows: Sequence[MeasureRow], scale: float) -> None:
    """The targets on a Bode plot: the GM level below 0 dB and the PM level above
    -180 deg (at the crossings), a crossover bound, a modal-peak ceiling."""
    gm, pm = _desired(rows, "gain_margin_db"), _desired(rows, "phase_margin_deg")
    if gm is not None:
        mag.axhline(-gm.desired, **_requirement_style(gm), label=f"GM >= {gm.desired:g} dB (at phase crossovers)")
    if pm is not None:
        phase.axhline(
            -180 + pm.desired, **_requirement_style(pm), label=f"PM >= {pm.desired:g} deg (at gain crossovers)"
        )
    wc = _desired(rows, "crossover_frequency")
    if wc is not None:
        sense = ">=" if wc.at_least else "<="
        mag.axvline(wc.desired / scale, **_requirement_style(wc), label=f"crossover {sense} {wc.desired:g} rad/s")
    peak = _desired(rows, "modal_peak_db")
    if peak is not None:
        mag.axhline(peak.desired, **_requirement_style(peak), label=f"modal peak <= {peak.desired:g} dB")


def bode(curves: list[LoopCurve], unit: str, title: str, rows: Sequence[MeasureRow] = ()) -> bytes:
    """Magnitude and phase against frequency; gain margins (at phase crossovers) and
    phase margins (at gain crossovers) of the curves that carry them, marked; the
    requirements of ``rows`` (a tableau's) drawn."""
    fig, (mag, phase) = _figure(2)
    scale = 2 * np.pi if unit == "hz" else 1.0
    for c in curves:
        mag.semilogx(c.omega / scale, _db(c.gh), _style(c), label=c.label)
        phase.semilogx(c.omega / scale, _phase(c.gh), _style(c), label=c.label)
        for m in c.margins.listed("G") if c.margins else ():  # a delay's periodic family: its few
            if m.frequency > 0 and m.gain_db is not None and np.isfinite(m.gain_db):
                mag.plot([m.frequency / scale] * 2, [0.0, -m.gain_db], "r-", lw=1.5)
                mag.annotate(f"GM {m.gain_db:.3g} dB", (m.frequency / scale, -m.gain_db), fontsize=7)
        for m in c.margins.phase if c.margins else ():
            wrapped = np.degrees(np.angle(m.gh))
            mag.plot([m.frequency / scale], [0.0], "go", ms=4)
            phase.annotate(f"PM {m.phase_deg:.3g} deg", (m.frequency / scale, wrapped), fontsize=7)
    mag.axhline(0.0, color="k", lw=0.5)
    for k in (-180.0, -540.0, 180.0):
        phase.axhline(k, color="k", lw=0.5, ls=":")
    _bode_requirements(mag, phase, rows, scale)
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
        ax.set_aspect("equal", adjustable="datalim")
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


def nichols(curves: list[LoopCurve], title: str) -> bytes:
    """Magnitude (dB) against phase (deg), with the critical point (-180 deg, 0 dB)."""
    fig, (ax,) = _figure()
    for c in curves:
        ax.plot(_phase(c.gh), _db(c.gh), _style(c), label=c.label)
    ax.plot([-180.0], [0.0], "r+", ms=12, mew=2)
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
