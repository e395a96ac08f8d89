"""The design report's figures, drawn with matplotlib's Agg backend into PNG bytes.

matplotlib is imported inside the functions (the report alone needs it, and
the command line starts without it).  Each figure shows the final design
(solid) beside the initial one (dashed) of one flight condition: Bode with
the margins marked, Nyquist with -1 and the targets' circles around it (each
margin target in its distance form |1 + GH|, report 000), Nichols, and the
closed-loop step response; and the convergence history.
"""

from __future__ import annotations

import io

import numpy as np

from engine.analysis import LoopCurve
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


def _db(gh: np.ndarray) -> np.ndarray:
    with np.errstate(all="ignore"):
        return 20 * np.log10(np.abs(gh))


def _phase(gh: np.ndarray) -> np.ndarray:
    return np.degrees(np.unwrap(np.angle(gh)))


def bode(curves: list[LoopCurve], unit: str, title: str) -> bytes:
    """Magnitude and phase against frequency; gain margins (at phase crossovers) and
    phase margins (at gain crossovers) of the curves that carry them, marked."""
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
    mag.set_ylabel("magnitude (dB)")
    phase.set_ylabel("phase (deg)")
    phase.set_xlabel(f"frequency ({unit})")
    mag.set_title(title)
    mag.legend(fontsize=7)
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


def step(traces: list[tuple[np.ndarray, np.ndarray, str, str]], what: str, title: str) -> bytes:
    """Step responses (t, y, label, line style)."""
    fig, (ax,) = _figure()
    for t, y, label, style in traces:
        ax.plot(t, y, style, label=label)
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
