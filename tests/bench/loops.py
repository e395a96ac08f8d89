"""Margins and responses of built loops against python-control, same process.

The loops: ``order/2`` second-order sections in series (lightly damped modes
from zeta = 0.005), up to 15 of them with free zeta and omega (so 30
parameters from order 30), unity feedback; 1000 frequencies.  Parameters
change by 1e-12 between repetitions so no cache answers."""

from __future__ import annotations

import warnings

import control as ct
import numpy as np

from engine.loop.responses import loop_model, open_loop
from engine.margins.search import margins
from engine.model.blocks import ExpressionTransfer
from engine.model.network import Block, Junction, block_diagram
from tests.bench.common import compared, perturbed, samples, scaling, timed

ORDERS = (2, 4, 10, 20, 40, 80, 160)
FREE = 15
OMEGA = np.geomspace(0.01, 1000.0, 1000)


def ratio_target(order: int) -> float:
    """python-control's time over ours: at least 1.5 at orders 2-10, 3 from 20."""
    return 1.5 if order < 20 else 3.0


def benchmark_loop(sections: int = 20, free: int = FREE):
    """(network, params, num, den) of ``sections`` second-order sections in
    series, the first ``free`` of them with free zeta and omega."""
    rng = np.random.default_rng(7)
    blocks, params, previous = [], {}, "e"
    num, den = np.array([1.0]), np.array([1.0])
    for k in range(sections):
        wp, zp = 10 ** rng.uniform(-0.5, 2), 10 ** rng.uniform(np.log10(0.005), -0.3)
        wz, zz = wp * 10 ** rng.uniform(-0.3, 0.3), 10 ** rng.uniform(np.log10(0.005), -0.3)
        out = "y" if k == sections - 1 else f"x{k}"
        if k < free:
            params[f"z{k}"], params[f"w{k}"] = zp, wp
            den_text = f"(s**2/w{k}**2 + 2*z{k}*s/w{k} + 1)"
        else:
            den_text = f"(s**2/{wp!r}**2 + 2*{zp!r}*s/{wp!r} + 1)"
        gain = 3.0 if k == 0 else 1.0
        text = f"{gain}*(s**2/{wz!r}**2 + 2*{zz!r}*s/{wz!r} + 1)/{den_text}"
        blocks.append(Block(f"S{k}", previous, out, ExpressionTransfer(text)))
        num = np.polymul(num, gain * np.array([1 / wz**2, 2 * zz / wz, 1.0]))
        den = np.polymul(den, np.array([1 / wp**2, 2 * zp / wp, 1.0]))
        previous = out
    net = block_diagram(blocks, [Junction("sum", "e", ((1.0, "r"), (-1.0, "y")))], ["r"])
    return net, params, num, den


def _pc_margins(system):
    def run(i=0):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return ct.stability_margins(system, returnall=True)

    return run


def _pc_fails(system) -> str | None:
    """Why python-control cannot give this loop's margins (None when it can)."""
    try:
        _pc_margins(system)()
    except (ValueError, ArithmeticError, np.linalg.LinAlgError) as exc:
        return f"{type(exc).__name__}: {exc}"
    return None


def dense_check(loop, found, points: int = 400_000) -> dict:
    """The margins against a dense log grid on the exact network: as many
    gain crossovers (|GH| = 1) and phase crossovers of the negative real
    axis, and every crossover found on its level to 1e-9."""
    lo = min(loop.corner_frequencies.min(), 1.0) * 1e-3
    hi = max(loop.corner_frequencies.max(), 1.0) * 1e3
    w = np.geomspace(lo, hi, points)
    gh = np.concatenate([loop.exact(part)[0] for part in np.array_split(w, 40)])
    level = np.abs(gh) - 1.0
    crossings = int(np.sum(np.sign(level[1:]) != np.sign(level[:-1])))
    turns = np.flatnonzero((np.sign(gh.imag[1:]) != np.sign(gh.imag[:-1])) & (gh.real[1:] < 0))
    on_level = [abs(abs(loop.exact(np.array([m.frequency]))[0][0]) - 1.0) for m in found.phase]
    checked = (
        crossings == len(found.phase)
        and turns.size == len([m for m in found.gain if m.frequency > 0])
        and max(on_level, default=0.0) < 1e-9
    )
    return {
        "dense_points": points,
        "phase_crossovers_dense": crossings,
        "phase_margins": len(found.phase),
        "gain_crossings_dense": int(turns.size),
        "gain_margins": len(found.gain),
        "worst_level_error": max(on_level, default=0.0),
        "checked": bool(checked),
    }


def margins_by_order(repeat: int, orders=ORDERS) -> dict:
    """Every margin of the built loop against python-control's
    stability_margins(returnall=True), per order, interleaved."""
    out, ours_times = {}, []
    for order in orders:
        net, params, num, den = benchmark_loop(order // 2, min(FREE, order // 2))
        system = ct.tf(num, den)
        built = [loop_model(net, "e", OMEGA, perturbed(params, i)) for i in range(repeat + 1)]

        def ours(i=0, built=built):
            return margins(built[i], attenuation_above=0.0)

        failure = _pc_fails(system)
        if failure is None:
            figure = compared(ours, _pc_margins(system), repeat, ratio_target(order), order=order)
        else:  # python-control fails: our time, and our answer checked
            check = dense_check(built[0], ours())
            figure = {
                "order": order,
                "ours_median_s": float(np.median(samples([ours], repeat)[0])),
                "python_control": failure,
                **check,
                "target": "answer checked on a dense grid",
                "target_kind": "check",
                "met": check["checked"],
                "enforced": True,
            }
        out[f"order_{order}"] = figure
        ours_times.append(figure["ours_median_s"])
    out["scaling_vs_order"] = scaling("order", list(orders), ours_times)
    return out


def with_building(repeat: int) -> dict:
    """The 40th-order loop: margins including building the loop at new
    parameter values, against python-control (which starts from its tf)."""
    net, params, num, den = benchmark_loop()

    def ours(i=0):
        return margins(loop_model(net, "e", OMEGA, perturbed(params, i)), attenuation_above=0.0)

    m = ours()
    return compared(
        ours,
        _pc_margins(ct.tf(num, den)),
        repeat,
        order=40,
        found={"G": len(m.gain), "P": len(m.phase), "S": len(m.stability), "A": len(m.attenuation)},
    )


def responses(repeat: int) -> dict:
    """The open-loop response of the 40th-order loop: with all 30
    sensitivities (target 5 ms), and like with like against python-control's
    frequency response (ours without sensitivities); scaling with the number
    of frequencies and of parameters."""
    net, params, num, den = benchmark_loop()
    system = ct.tf(num, den)

    def ours(sens: bool, omega=OMEGA, net=net, params=params):
        return lambda i=0: open_loop(net, "e", omega, perturbed(params, i), sensitivities=sens)

    assert ours(True)().sensitivity.shape == (1000, 30)
    with_sens = samples([ours(True)], repeat)[0]
    out = {
        "with_sensitivities": timed(float(np.median(with_sens)), 0.005, parameters=30, frequencies=OMEGA.size),
        "no_sensitivities_vs_python_control": compared(
            ours(False), lambda i=0: system(1j * OMEGA), repeat, note="reported: issue 23 sets no target"
        ),
    }
    points = (250, 1000, 4000)
    by_points = samples([ours(True, np.geomspace(0.01, 1000.0, n)) for n in points], max(repeat // 2, 5))
    out["scaling_vs_points"] = scaling("frequencies", points, [float(np.median(t)) for t in by_points])
    free = (5, 10, 15, 20)
    loops = [benchmark_loop(20, f)[:2] for f in free]
    by_free = samples([ours(True, OMEGA, n, p) for n, p in loops], max(repeat // 2, 5))
    out["scaling_vs_parameters"] = scaling("parameters", [2 * f for f in free], [float(np.median(t)) for t in by_free])
    return out
