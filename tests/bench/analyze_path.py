"""`loopcraft analyze --tf EXPR --json` in process (parse, build, margins,
closed-loop poles, disk margin and sensitivity peaks, the JSON text) against
python-control doing the same from the typed expression (tf from the text,
stability_margins(returnall=True), feedback(L, 1).poles() and disk_margins
on the command's default 400-point grid: the enforced ratio), and against
python-control without the disk margin (the issue's first definition, from
before analyze computed disk margins and peaks: reported), interleaved.
The gain changes by 1e-12 between repetitions so no cache of a parsed or
compiled expression answers.

`state_space_any_coordinates`: `loopcraft analyze --ss FILE.npz --json` in process on
random models of order 20, 50 and 100 (tests/engine/test_state_space_coordinates.py's
`model`, lightly damped modes over five decades) with their states scaled by powers of two
up to 2^+-40, a new model at every repetition: at most 2 s each (issue 49; before balancing,
an order-82 model took over 4 minutes)."""

from __future__ import annotations

import argparse
import contextlib
import io
import tempfile
import warnings
from pathlib import Path

import control as ct
import numpy as np

from tests.bench.common import compared, median_time, timed
from tests.engine.test_state_space_coordinates import model, scaled

EXPRESSIONS = {  # order: (gain, the rest of the typed expression)
    4: (10.0, "*(s+2)/(s*(s+1)*(s+5)*(s+20))"),
    10: (50.0, "*(s+1)*(s+3)/(s*(s+0.5)*(s+2)*(s+5)*(s+10)*(s**2+0.4*s+4)*(s**2+2*s+50)*(s+40))"),
    20: (
        1e3,
        "*(s+1)*(s+3)*(s**2+0.2*s+9)/(s*(s+0.5)*(s+2)*(s+5)*(s+10)*(s**2+0.4*s+4)*(s**2+2*s+50)"
        "*(s+40)*(s**2+0.1*s+25)*(s**2+0.3*s+100)*(s+60)*(s+80)*(s**2+3*s+400)*(s+200)*(s+300))",
    ),
}


GRID = np.geomspace(1e-3, 1e3, 400)  # analyze's default plot grid (--wmin, --wmax, --points)


def ratio_target(order: int) -> float:
    """At least 1.5x from order 10; faster (above 1) below."""
    return 1.5 if order >= 10 else 1.0


def _parser() -> argparse.ArgumentParser:
    from tui.cli.analyze import add_parser

    parser = argparse.ArgumentParser()
    add_parser(parser.add_subparsers())
    return parser


def _texts(order: int, repeat: int) -> list[str]:
    gain, rest = EXPRESSIONS[order]
    return [f"{gain * (1.0 + 1e-12 * i)!r}{rest}" for i in range(repeat + 1)]


def analyze_path(repeat: int) -> dict:
    """Per order, the in-process CLI against python-control (see the module docstring)."""
    parser, s = _parser(), ct.tf("s")
    out = {}
    for order in EXPRESSIONS:
        texts = _texts(order, repeat)

        def ours(i=0, texts=texts):
            args = parser.parse_args(["analyze", "--tf", texts[i], "--json"])
            with contextlib.redirect_stdout(io.StringIO()) as text:
                args.handler(args)
            return text.getvalue()

        def theirs(i=0, texts=texts, disk=True):
            loop = eval(texts[i], {"__builtins__": {}}, {"s": s})  # the bench's own constant texts
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                found = ct.stability_margins(loop, returnall=True), ct.feedback(loop, 1).poles()
                return found + (ct.disk_margins(loop, GRID),) if disk else found

        out[f"order_{order}"] = compared(ours, theirs, repeat, ratio_target(order), order=order, expression=texts[0])
        out[f"order_{order}_without_disk_margins"] = compared(
            ours, lambda i=0: theirs(i, disk=False), repeat, order=order, note="python-control: margins and poles only"
        )
    return out


STATE_SPACE_ORDERS = (20, 50, 100)
STATE_SPACE_TARGET_S = 2.0


def state_space_any_coordinates(repeat: int) -> dict:
    """Per order, `analyze --ss` on scaled models (see the module docstring)."""
    parser, out = _parser(), {}
    with tempfile.TemporaryDirectory() as folder:
        for order in STATE_SPACE_ORDERS:

            def ours(i=0, order=order):
                A, B, C, D = model(order, i)
                As, Bs, Cs = scaled(A, B, C, i)
                path = Path(folder) / f"order_{order}_{i}.npz"
                np.savez(path, A=As, B=Bs, C=Cs, D=D)
                args = parser.parse_args(["analyze", "--ss", str(path), "--json"])
                with contextlib.redirect_stdout(io.StringIO()):
                    args.handler(args)

            out[f"order_{order}"] = timed(median_time(ours, max(3, repeat // 5)), STATE_SPACE_TARGET_S, order=order)
    return out
