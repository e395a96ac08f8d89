"""The launch-vehicle models behind the bundled `cip` examples, and the script
that writes their tables and sessions (run: python -m sessions.examples.launch_vehicles).

Report 000 tabulates the Saturn V / S1-C responses only as plots, so these
models are built here in their spirit and documented (docs/algorithms/cip.md).
theta/R (the uncompensated open loop, loop broken at the error) is

    (a0 + a1 s) / ((1 + s/w_act)(1 + s/w_filt)) x [ mu_c/(s^2 - mu_alpha)
                                           + sum_i k_i w_i^2/(s^2 + 2 zeta_i w_i s + w_i^2) ]

an aerodynamically unstable rigid body (pole at +sqrt(mu_alpha)) sensed
through attitude and rate gains, plus slosh and bending modes in parallel
(each mode adds its own pair of lightly damped zeros).  Each mode's gain k_i
is set so that its resonant peak in the loop with the initial compensator has
a chosen size and sign (a negative sign puts the first bending mode's peak in
the right half plane: phase stabilized, as in the report).  The dual-channel
vehicle feeds back attitude and rate (the listing's second channel is s times
the first) without the sensor blend.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
from numpy.polynomial import polynomial as P

HERE = Path(__file__).parent

# report 000, (E1-1): 0.9 x three second-order factors (ascending coefficients)
E1_1 = [
    ([1.0, 11.79440, 28.59200], [1.0, 21.56500, 6.05650]),
    ([100.0, 6.05720, 7.56640], [100.0, 10.06500, 6.32880]),
    ([1000.0, 19.08700, 3.73500], [1000.0, 330.35200, 19.02000]),
]
# (E2-1) and (E2-2): attitude and rate channels of the dual-channel example
E2_1 = [
    ([1000.0, 6.54732, 4.5732], [100.0, 1.43424]),
    ([100.0, 6.04029], [100.0, 6.17455]),
    ([10.0, 3.69000], [10.0, 2.32980]),
    ([0.1, 1.04000], [0.1, 2.33536]),
    ([1.0], [10.0, 1.05603]),
    ([100.0], [100.0, 4.13275]),
]
E2_2 = [
    ([1000.0, 2.91040, 4.50787], [100.0, 3.52502]),
    ([100.0, 4.71096], [100.0, 4.61899]),
    ([10.0], [100.0, 5.49396]),
    ([10.0], [10.0, 1.21426]),
    ([10.0], [10.0, 2.85080]),
]

# (frequency Hz, damping, peak of |GH| with the initial compensator; sign = side)
SINGLE = {
    "mu_alpha": 0.04,
    "mu_c": 0.2,
    "a0": 1.0,
    "a1": 1.5,
    "w_act": 2 * np.pi * 3.0,
    "w_filt": 2.0,
    "gain": 0.9,
    "modes": [
        (0.26, 0.005, 0.5),
        (0.536, 0.005, 0.3),
        (1.199, 0.01, -2.5),
        (2.59, 0.01, 0.28),
        (3.616, 0.005, 0.1),
        (4.57, 0.01, 0.2),
        (6.34, 0.01, 0.05),
        (8.58, 0.01, 0.4),
    ],
}
DUAL = {
    "mu_alpha": 0.04,
    "mu_c": 0.8,
    "a0": 1.0,
    "a1": 0.0,
    "w_act": 2 * np.pi * 4.0,
    "w_filt": np.inf,
    "gains": (1.26, 0.58),
    "modes": [
        (0.21, 0.005, 0.25),
        (0.52, 0.005, 0.3),
        (1.226, 0.01, -9.5),
        (2.68, 0.01, 0.15),
        (4.02, 0.01, 0.12),
        (8.39, 0.01, 0.05),
        (11.79, 0.01, 0.205),
    ],
}


def _cascade(factors: list, gain: float) -> tuple[np.ndarray, np.ndarray]:
    num, den = np.array([gain]), np.ones(1)
    for n, d in factors:
        num, den = P.polymul(num, n), P.polymul(den, d)
    return num, den


def _value(poly: tuple[np.ndarray, np.ndarray], s: np.ndarray) -> np.ndarray:
    return P.polyval(s, poly[0]) / P.polyval(s, poly[1])


def _sensing(model: dict) -> tuple[np.ndarray, np.ndarray]:
    den = P.polymul([1.0, 1.0 / model["w_act"]], [1.0, 0.0 if np.isinf(model["w_filt"]) else 1.0 / model["w_filt"]])
    return np.array([model["a0"], model["a1"]]) if model["a1"] else np.array([model["a0"]]), den


def plant(model: dict, compensator: tuple[np.ndarray, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """theta/R (ascending num, den); modes sized against the loop with ``compensator``."""
    sensing = _sensing(model)
    terms = [(np.array([model["mu_c"]]), np.array([-model["mu_alpha"], 0.0, 1.0]))]
    for f, zeta, peak in model["modes"]:
        w = 2 * np.pi * f
        rest = abs(_value(sensing, 1j * w) * _value(compensator, 1j * w))
        k = np.sign(peak) * abs(peak) * 2 * zeta / rest  # |mode term| at resonance is |k|/(2 zeta)
        terms.append((np.array([k * w * w]), np.array([w * w, 2 * zeta * w, 1.0])))
    num, den = np.zeros(1), np.ones(1)
    for n, d in terms:
        num, den = P.polyadd(P.polymul(num, d), P.polymul(n, den)), P.polymul(den, d)
    return P.polymul(num, sensing[0]), P.polymul(den, sensing[1])


def single_channel(f_hz: np.ndarray) -> np.ndarray:
    """theta/R of the single-channel vehicle at ``f_hz`` (without the 0.9 gain)."""
    comp = _cascade(E1_1, SINGLE["gain"])
    return _value(plant(SINGLE, comp), 2j * np.pi * f_hz)


def dual_channel(f_hz: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Attitude and rate responses (rate = s x attitude) of the dual-channel vehicle."""
    g1, g2 = _cascade(E2_1, DUAL["gains"][0]), _cascade(E2_2, DUAL["gains"][1])
    both = (P.polyadd(P.polymul(g1[0], g2[1]), P.polymul(P.polymul(g2[0], [0.0, 1.0]), g1[1])), P.polymul(g1[1], g2[1]))
    s = 2j * np.pi * f_hz
    attitude = _value(plant(DUAL, both), s)
    return attitude, s * attitude


SINGLE_GRID = np.geomspace(0.01, 10.0, 999)
DUAL_GRID = np.geomspace(0.01, 12.0, 357)


def _csv(path: Path, header: str, columns: list[np.ndarray]) -> None:
    lines = [header] + [",".join(f"{v:.12e}" for v in row) for row in zip(*columns)]
    path.write_text(
        "# generated by sessions/examples/launch_vehicles.py; see its docstring\n" + "\n".join(lines) + "\n"
    )


def _channel(name: str, csv: str, columns: list[str], gain: float, factors: list) -> tuple[dict, list]:
    """The channel's JSON and its parameters; its d.c. gain is held (the listing's KONT = 2)."""
    subs, params = [], []
    for k, (num, den) in enumerate(factors, start=1):
        entry = {"numerator": [], "denominator": []}
        for side, letter, coefficients in (("numerator", "x", num), ("denominator", "y", den)):
            for i, value in enumerate(coefficients):
                pname = f"{name}_{k}_{letter}{i}"
                entry[side].append(pname)
                params.append({"name": pname, "value": value, "min": 0.0})
        subs.append(entry)
    response = {"kind": "table", "table": {"unit": "hz", "form": "cartesian", "csv": csv, "columns": columns}}
    return {"name": name, "response": response, "gain": gain, "compensators": subs, "hold_dc_gain": True}, params


def _session(notes: str, channels: list[dict], params: list, grid: dict, targets: list, settings: dict) -> dict:
    stamp = "2026-11-23T00:00:00+00:00"
    return {
        "schema_version": 2,
        "provenance": {"loopcraft_version": "0.1.0", "created": stamp, "modified": stamp},
        "notes": notes,
        "algorithm": {"name": "cip", "settings": settings},
        "records": [],
        "current_iteration": 0,
        "state": None,
        "problem": {
            "grid": grid,
            "parameters": params,
            "targets": targets,
            "conditions": [{"name": "flight", "break_at": "e", "plant": {"format": "channels", "channels": channels}}],
        },
    }


def write_examples(folder: Path = HERE) -> None:
    """Write both tables and both sessions."""
    single = single_channel(SINGLE_GRID)
    _csv(folder / "cip_launch_vehicle.csv", "f_hz,real,imag", [SINGLE_GRID, single.real, single.imag])
    attitude, rate = dual_channel(DUAL_GRID)
    _csv(
        folder / "cip_dual_channel.csv",
        "f_hz,attitude_real,attitude_imag,rate_real,rate_imag",
        [DUAL_GRID, attitude.real, attitude.imag, rate.real, rate.imag],
    )
    channel, params = _channel("vehicle", "cip_launch_vehicle.csv", ["f_hz", "real", "imag"], SINGLE["gain"], E1_1)
    targets = [
        {"measure": "gain_margin", "unit": "hz", "detect_low": 0.01, "detect_high": 0.1, "bands": [{"desired": 1.0}]},
        {
            "measure": "phase_margin",
            "unit": "hz",
            "detect_low": 1.0,
            "detect_high": 1.4,
            "bands": [{"high": 1.199, "desired": 0.9}, {"low": 1.199, "desired": 1.3}],
        },
        {"measure": "stability_margin", "bands": [{"desired": 0.505}]},
        {"measure": "attenuation_margin", "unit": "hz", "detect_low": 2.1, "bands": [{"desired": 0.25}]},
    ]
    grid = {"unit": "hz", "start": 0.01, "stop": 10.0, "points": 999, "spacing": "log"}
    notes = (
        "Report 000, single-channel example in spirit: an unstable launch vehicle (rigid body, two slosh "
        "modes, six bending modes, first bending 1.199 Hz) tabulated at 999 points, 0.01-10 Hz, with the "
        "initial compensator (E1-1). Targets: aero gain margin pushed from -1 (distance 1.0), lead/lag phase "
        "margins of the first bending mode 0.9/1.3, stability margins 0.505, attenuation 0.25 above 2.1 Hz."
    )
    settings = {"mode": "tifr", "max_step": 0.1, "min_step": 1e-4, "max_iterations": 200, "gain_as_stability": True}
    _dump(folder / "cip_launch_vehicle.json", _session(notes, [channel], params, grid, targets, settings))
    ch1, p1 = _channel(
        "attitude", "cip_dual_channel.csv", ["f_hz", "attitude_real", "attitude_imag"], DUAL["gains"][0], E2_1
    )
    ch2, p2 = _channel("rate", "cip_dual_channel.csv", ["f_hz", "rate_real", "rate_imag"], DUAL["gains"][1], E2_2)
    targets = [
        {
            "measure": "gain_margin",
            "unit": "hz",
            "detect_low": 0.01,
            "detect_high": 0.1,
            "bands": [{"desired": 4.8}],
            "points": [{"real": -1.0, "mode": "push"}, {"real": -7.0, "imag": -3.0, "mode": "pull"}],
        },
        {
            "measure": "phase_margin",
            "unit": "hz",
            "detect_low": 1.0,
            "detect_high": 1.4,
            "bands": [{"high": 1.226, "desired": 0.9}, {"low": 1.226, "desired": 1.3}],
            "points": [{"real": 1.0, "mode": "pull"}],
        },
        {"measure": "stability_margin", "bands": [{"desired": 0.49}]},
        {
            "measure": "attenuation_margin",
            "unit": "hz",
            "detect_low": 1.0,
            "bands": [{"low": 1.05, "high": 1.4, "desired": 9.0}, {"low": 2.0, "desired": 0.2}],
        },
    ]
    grid = {"unit": "hz", "start": 0.01, "stop": 12.0, "points": 357, "spacing": "log"}
    notes = (
        "Report 000, dual-channel example in spirit: attitude and rate channels (rate = s x attitude) of an "
        "unstable vehicle with slosh and five bending modes, 357 points, 0.01-12 Hz, initial compensators "
        "(E2-1)/(E2-2). The aero gain margin (desired 4.8) is pushed from -1 and pulled towards -7-j3."
    )
    notes += (
        " Run with TIFR plus this program's guard against slippage (guard_band 0.05: met margins within "
        "5% of desired also steer the direction; keep_met: a move may not make a met margin unmet)."
    )
    settings = dict(settings, guard_band=0.05, keep_met=True)
    _dump(folder / "cip_dual_channel.json", _session(notes, [ch1, ch2], p1 + p2, grid, targets, settings))


def _dump(path: Path, session: dict) -> None:
    path.write_text(json.dumps(session, indent=1, sort_keys=True) + "\n")


if __name__ == "__main__":
    write_examples()
