"""Every loop of a square plant, one at a time and all together: at each break the
single-input single-output loop with every other loop closed (`engine.multiloop.plant.loop_at`,
a realization of the plant's n states) is analyzed as one loop is (`engine.analysis.analyze`:
gain, phase and delay margins at every crossing, the disk margin, Ms and Mt, the closed-loop
poles), and the multi-loop disk margin (`engine.multiloop.disk`) is computed once."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import ArrayLike

from engine.analysis import LoopAnalysis, analyze, closed_loop_peaks, margins_with_peaks, unity_feedback
from engine.errors import EngineError
from engine.loop.responses import loop_model
from engine.loop.sampled import analyze_sampled
from engine.margins.disk import DiskMargin
from engine.margins.peaks import Peak
from engine.margins.search import Margins
from engine.model.bilinear import real_frequency, realization_in_w
from engine.model.blocks import StateSpaceTransfer
from engine.multiloop.disk import STABLE, MultiLoopDiskMargin, multi_loop_disk_margin
from engine.multiloop.plant import Plant, balanced_plant, closed_loop_poles, loop_at
from engine.multiloop.simultaneous import SimultaneousMargin, simultaneous


@dataclass(frozen=True)
class LoopsAnalysis:
    """``loops``: (break name, its single-loop analysis) for each break asked for;
    ``together``: the multi-loop disk margin (None when not asked for); ``gain_only``,
    ``phase_only``: the simultaneous margins (None when not asked for)."""

    loops: tuple[tuple[str, LoopAnalysis], ...]
    together: MultiLoopDiskMargin | None
    gain_only: SimultaneousMargin | None = None
    phase_only: SimultaneousMargin | None = None


def break_loop(plant: Plant, name: str, source: str = "plant") -> StateSpaceTransfer:
    """The loop at the break ``name`` as a state-space block (an `EngineError` naming a break
    that is not the plant's, or a loop that is 0 at every frequency: it opens no loop)."""
    m = loop_at(plant, plant.index(name))
    transfer = StateSpaceTransfer(m.A, m.B, m.C, m.D, f"{source} at {name}")
    if transfer.form.gain == 0:
        raise EngineError(f"break {name}: the loop seen there is 0 at every frequency (it opens no loop)")
    return transfer


def analyze_breaks(
    plant: Plant,
    omega: ArrayLike,
    breaks: Sequence[str] | None = None,
    skew: float = 0.0,
    together: bool = True,
    source: str = "plant",
    sample_time: float | None = None,
    both_kinds: bool = False,
) -> LoopsAnalysis:
    """Loop at a time at each of ``breaks`` (all when None) and, when ``together``, all at once;
    with a ``sample_time`` the plant is in z (x[k+1] = A x[k] + B u[k]): each loop by the sampled
    analysis (`engine.loop.sampled`), all together on the plant's w-plane form (`sampled_together`);
    ``both_kinds``: the simultaneous gain-only and phase-only margins too (a plant in s), bracketed
    from the balanced (skew 0) disk (`engine.multiloop.simultaneous`)."""
    names = list(plant.names if breaks is None else breaks)
    w = np.asarray(omega, dtype=float)
    found = []
    for name in names:
        transfer = break_loop(plant, name, source)
        if sample_time is None:
            found.append((name, analyze(unity_feedback(["1"], state_space=transfer), "e", w, {}, skew=skew)))
        else:
            network = unity_feedback(["1"], "z", state_space=transfer)
            found.append((name, analyze_sampled(network, "e", w, {}, sample_time, skew=skew)))
    if not together:
        return LoopsAnalysis(tuple(found), None)
    disk = multi_loop_disk_margin(plant, skew) if sample_time is None else sampled_together(plant, sample_time, skew)
    if not both_kinds or sample_time is not None:
        return LoopsAnalysis(tuple(found), disk)
    balanced = disk if skew == 0 else multi_loop_disk_margin(plant)
    gain, phase = simultaneous(plant, "gain", balanced), simultaneous(plant, "phase", balanced)
    return LoopsAnalysis(tuple(found), disk, gain, phase)


def sampled_together(plant: Plant, sample_time: float, skew: float = 0.0) -> MultiLoopDiskMargin:
    """The multi-loop disk margin of a plant in z: that of its w-plane form (z = (1 + w)/(1 - w) maps
    the unit circle onto the imaginary axis, so the maximum of mu over frequency is the same), its
    frequency nu back in rad/s, omega = 2 atan(nu) / T (inf: the Nyquist frequency)."""
    a, b, c, d = realization_in_w(plant.A, plant.B, plant.C, plant.D)
    found = multi_loop_disk_margin(balanced_plant(Plant(a, b, c, d, plant.names)), skew)
    omega = float(real_frequency(found.frequency, sample_time)) if math.isfinite(found.frequency) else math.nan
    if found.frequency == math.inf:
        omega = math.pi / sample_time
    note = f"a plant in z (sample time {sample_time:g} s): searched on its w-plane form, the frequency in rad/s"
    return replace(found, frequency=omega, notes=found.notes + (note,))


@dataclass(frozen=True)
class BreakMargins:
    """One break's margins alone (no closed-loop pole list, no fixed modes): gain, phase and delay
    margins at every crossing, the disk margin, Ms and Mt."""

    name: str
    margins: Margins
    disk_margin: DiskMargin | None
    sensitivity_peak: Peak | None
    complementary_peak: Peak | None


def break_margins(plant: Plant, omega: ArrayLike, skew: float = 0.0) -> tuple[BreakMargins, ...]:
    """Every break's margins by the single-loop search, the closed loop's stability read once from
    the plant (the same closed loop at every break: eigenvalues of A - B (I + D)^-1 C)."""
    poles = closed_loop_poles(plant)
    size = 1.0 + (np.abs(plant.A).sum(axis=0).max() if plant.order else 0.0)
    verdict = "stable" if not poles.size or poles.real.max() < -STABLE * size else "unstable"
    w = np.asarray(omega, dtype=float)
    out = []
    for name in plant.names:
        model = loop_model(unity_feedback(["1"], state_space=break_loop(plant, name)), "e", w, {})
        found, peaks = margins_with_peaks(model, skew)
        disk, ms, mt, _ = closed_loop_peaks(model, verdict, skew, peaks)
        out.append(BreakMargins(name, found, disk, ms, mt))
    return tuple(out)
