"""The launch vehicle of the bundled `slp` example (report 003, Appendix B,
Examples 5 and 6 in spirit), and the script that writes its session
(run: python -m sessions.examples.coebra_launch_vehicle).

Report 003 prints no airframe data, so this model is built here from the
textbook pitch-plane equations (Greensite; Harris) and documented in
docs/algorithms/slp.md.  Per flight condition (load-relief switch-in, max-q, switch-out):

  rigid body   theta'' = mu_a alpha + mu_c delta       (mu_a > 0: aerodynamically unstable)
               gamma'  = Z_a alpha + Z_d delta          (drift: flight-path angle)
               alpha   = theta - gamma + alpha_w        (alpha_w: wind angle of attack, an input)
  bending      q_i'' + 2 zeta_i w_i q_i' + w_i^2 q_i = b_i delta     (three modes)
  sensors      attitude  theta_s = theta - s_i q_i,   rate r_s = theta' - r_i q_i'
               accelerometer a_s = V gamma' + l_a theta'' + p_i q_i''
  actuator     delta = -w_act^2/(s^2 + 2 0.7 w_act s + w_act^2) dc
  autopilot    dc = F(s) [KD/(1+TA s) theta_s + KR/(1+TR s) r_s + KL/(1+TL s) a_s]
               F(s) = WF^2/(s^2 + 2 ZF WF s + WF^2), a second-order bending filter.

KD, KR and KL (attitude, rate, load-relief gains) have a value per flight
condition; TA, TR, TL, ZF and WF are shared.  The loop is broken at the
actuator command dc (the design's primary break); the condition's `breaks` add
each sensor path's output (u_att, u_rate, u_acc): the margins of that path's
loop with the others closed, and the multi-loop disk margin at all four.  The wind is a shear: alpha_w ramps from 0 to 0.1 rad
over 2 s and holds (a true step would put its whole size into alpha at
t = 0+, before any autopilot can act, so its peak could not be changed).
"""

from __future__ import annotations

import json
from pathlib import Path

HERE = Path(__file__).parent

# per condition: rigid body, speed, accelerometer arm, modes (w rad/s, zeta, b, gyro slope, rate slope, accel slope)
CONDITIONS = {
    "switch-in": {
        "mu_a": 0.25,
        "mu_c": 2.2,
        "Z_a": 0.02,
        "Z_d": 0.01,
        "V": 350.0,
        "l_a": 12.0,
        "modes": [
            (11.0, 0.01, 40.0, 0.012, 0.012, -0.05),
            (24.0, 0.01, 120.0, -0.006, -0.008, 0.04),
            (38.0, 0.015, 200.0, 0.004, 0.006, -0.03),
        ],
    },
    "max-q": {
        "mu_a": 0.45,
        "mu_c": 2.6,
        "Z_a": 0.03,
        "Z_d": 0.012,
        "V": 480.0,
        "l_a": 12.0,
        "modes": [
            (11.8, 0.01, 43.0, 0.012, 0.012, -0.05),
            (25.0, 0.01, 130.0, -0.006, -0.008, 0.04),
            (40.0, 0.015, 220.0, 0.004, 0.006, -0.03),
        ],
    },
    "switch-out": {
        "mu_a": 0.30,
        "mu_c": 3.0,
        "Z_a": 0.025,
        "Z_d": 0.014,
        "V": 620.0,
        "l_a": 12.0,
        "modes": [
            (12.6, 0.01, 46.0, 0.012, 0.012, -0.05),
            (26.5, 0.01, 140.0, -0.006, -0.008, 0.04),
            (42.0, 0.015, 240.0, 0.004, 0.006, -0.03),
        ],
    },
}
ACTUATOR = 40.0  # rad/s
# every loop break analyze and the report show: the actuator command (the design's primary break) and each
# sensor path's output (that path's loop, the actuator command and the other paths closed)
BREAKS = ("dc", "u_att", "u_rate", "u_acc")
# the poor start: gains too low for the max-q instability, a filter that eats the phase margin
START = {
    "KD": [0.5, 0.5, 0.5],
    "KR": [0.15, 0.15, 0.15],
    "KL": [0.0005, 0.0005, 0.0005],
    "TA": 0.05,
    "TR": 0.05,
    "TL": 0.5,
    "ZF": 0.5,
    "WF": 20.0,
}
BOUNDS = {
    "KD": (0.2, 5.0),
    "KR": (0.05, 3.0),
    "KL": (0.0, 0.01),
    "TA": (0.005, 1.0),
    "TR": (0.005, 1.0),
    "TL": (0.05, 5.0),
    "ZF": (0.2, 1.0),
    "WF": (4.0, 40.0),
}


def _block(name: str, source: str, target: str, expression: str) -> dict:
    return {
        "name": name,
        "input": source,
        "output": target,
        "transfer": {"kind": "expression", "expression": expression},
    }


def _condition(name: str, c: dict) -> dict:
    """One flight condition as a block diagram (see the module docstring)."""
    wa = ACTUATOR
    blocks = [
        _block("actuator", "dc", "delta", f"-{wa * wa:g}/(s^2+{1.4 * wa:g}*s+{wa * wa:g})"),
        _block("aero", "alpha", "m_alpha", f"{c['mu_a']:g}"),
        _block("control", "delta", "m_delta", f"{c['mu_c']:g}"),
        _block("pitch", "thdd", "thd", "1/s"),
        _block("attitude", "thd", "theta", "1/s"),
        _block("lift", "alpha", "g_alpha", f"{c['Z_a']:g}"),
        _block("side force", "delta", "g_delta", f"{c['Z_d']:g}"),
        _block("drift", "gdot", "gamma", "1/s"),
        _block("normal acceleration", "gdot", "a_cg", f"{c['V']:g}"),
        _block("arm", "thdd", "a_arm", f"{c['l_a']:g}"),
    ]
    attitude_sum, rate_sum, accel_sum = ["theta"], ["thd"], ["a_cg", "a_arm"]
    minus_attitude, minus_rate = [], []
    for i, (w, zeta, b, slope, rate_slope, accel_slope) in enumerate(c["modes"], start=1):
        den = f"(s^2+{2 * zeta * w:g}*s+{w * w:g})"
        blocks += [
            _block(f"mode {i} gyro", "delta", f"q{i}_att", f"{b * slope:g}/{den}"),
            _block(f"mode {i} rate gyro", "delta", f"q{i}_rate", f"{b * rate_slope:g}*s/{den}"),
            _block(f"mode {i} accelerometer", "delta", f"q{i}_acc", f"{b * accel_slope:g}*s^2/{den}"),
        ]
        minus_attitude.append(f"q{i}_att")
        minus_rate.append(f"q{i}_rate")
        accel_sum.append(f"q{i}_acc")
    blocks += [
        _block("attitude path", "theta_s", "u_att", "KD/(1+TA*s)"),
        _block("rate path", "r_s", "u_rate", "KR/(1+TR*s)"),
        _block("load-relief path", "a_s", "u_acc", "KL/(1+TL*s)"),
        _block("bending filter", "v", "dc", "WF^2/(s^2+2*ZF*WF*s+WF^2)"),
    ]
    junctions = [
        {"name": "moments", "output": "thdd", "plus": ["m_alpha", "m_delta"]},
        {"name": "forces", "output": "gdot", "plus": ["g_alpha", "g_delta"]},
        {"name": "angle of attack", "output": "alpha", "plus": ["theta", "alpha_w"], "minus": ["gamma"]},
        {"name": "attitude gyro", "output": "theta_s", "plus": attitude_sum, "minus": minus_attitude},
        {"name": "rate gyro", "output": "r_s", "plus": rate_sum, "minus": minus_rate},
        {"name": "accelerometer", "output": "a_s", "plus": accel_sum},
        {"name": "autopilot", "output": "v", "plus": ["u_att", "u_rate", "u_acc"]},
    ]
    return {
        "name": name,
        "break_at": "dc",
        "breaks": list(BREAKS),
        "variable": "s",
        "plant": {"format": "diagram", "inputs": ["alpha_w"], "blocks": blocks, "junctions": junctions},
    }


def _parameters() -> list[dict]:
    return [
        {"name": name, "value": value, "min": BOUNDS[name][0], "max": BOUNDS[name][1]} for name, value in START.items()
    ]


def _targets() -> list[dict]:
    wind = {
        "input": "alpha_w",
        "output": "alpha",
        "horizon": 10.0,
        "points": 201,
        "profile": [{"time": 0.0, "slope": 0.05}, {"time": 2.0, "slope": -0.05}],
        "reference": 0.0,
    }
    return [
        {
            "measure": "gain_margin_db",
            "sense": "at_most",
            "bands": [{"high": 1.0, "desired": -8.0, "required": -6.0}],
            "scale": 1.0,
        },
        {"measure": "gain_margin_db", "bands": [{"low": 1.0, "high": 8.0, "desired": 8.0, "required": 6.0}]},
        {
            "measure": "phase_margin_deg",
            "bands": [{"low": 0.5, "high": 8.0, "desired": 40.0, "required": 30.0}],
            "scale": 0.2,
        },
        {"measure": "crossover_frequency", "bands": [{"high": 8.0, "desired": 2.0, "required": 1.5}]},
        {
            "measure": "modal_peak_db",
            "bands": [
                {"low": 8.0, "high": 16.0, "desired": -10.0, "required": -6.0},
                {"low": 16.0, "high": 32.0, "desired": -12.0, "required": -10.0},
                {"low": 32.0, "high": 60.0, "desired": -12.0, "required": -10.0},
            ],
            "scale": 0.5,
        },
        {
            "measure": "peak_response",
            "requirement": False,
            "weight": 1.0,
            "scale": 100.0,
            "bands": [{"desired": 0.0}],
            "response": wind,
        },
    ]


def session() -> dict:
    stamp = "2026-11-23T00:00:00+00:00"
    notes = (
        "Report 003, Appendix B Examples 5 and 6 in spirit: three flight conditions (load-relief switch-in, "
        "max-q, switch-out), each a rigid body with aerodynamic instability, drift, a second-order actuator "
        "and three bending modes, with attitude, rate and accelerometer (load-relief) loops; gains KD, KR, KL "
        "per condition, filters TA, TR, TL, ZF, WF shared (the model: sessions/examples/"
        "coebra_launch_vehicle.py). Phase 1 (objective 'margins'): meet every margin from a poor start. "
        "Phase 2: `loopcraft run FILE --adopt --set objective=load_relief --until-done` lowers the peak "
        "angle of attack under a wind shear while every margin stays met."
    )
    return {
        "schema_version": 2,
        "provenance": {"loopcraft_version": "0.1.0", "created": stamp, "modified": stamp},
        "notes": notes,
        "algorithm": {"name": "slp", "settings": {"max_major": 20, "step_floor": 0.05}},
        "records": [],
        "current_iteration": 0,
        "state": None,
        "problem": {
            "grid": {"unit": "rad/s", "start": 0.01, "stop": 200.0, "points": 400, "spacing": "log"},
            "parameters": _parameters(),
            "targets": _targets(),
            "conditions": [_condition(name, c) for name, c in CONDITIONS.items()],
        },
    }


def write_example(folder: Path = HERE) -> None:
    (folder / "coebra_launch_vehicle.json").write_text(json.dumps(session(), indent=1) + "\n")


if __name__ == "__main__":
    write_example()
