"""A tabulated block in an export: its table as it is (python-control's and MATLAB's
``frd`` read it back exactly), or on request its rational model (the AAA fit, far
right-half-plane roots dropped, the residual restated on the table:
engine/loop/table_model.py); a model the data cannot justify (right-half-plane roots
outside the band, a residual above 1e-3) is refused: a peer tool would read margins
off it."""

from __future__ import annotations

import numpy as np

from engine.errors import EngineError
from engine.loop.table_model import table_model
from engine.model.blocks import TabulatedTransfer
from sessions.errors import SessionError


def table_fields(transfer: TabulatedTransfer) -> dict:
    """A table's frequencies (rad/s, those above 0) and its response there."""
    table = transfer.table
    keep = table.omega > 0
    return {
        "kind": "table",
        "text": transfer.text,
        "omega": tuple(table.omega[keep].tolist()),
        "response": tuple(complex(v) for v in table.response[keep]),
    }


def fit_fields(transfer: TabulatedTransfer) -> dict:
    """A table's rational model as gain, zeros, poles and coefficients, with its residual and
    degree; a `SessionError` where the model is refused."""
    table = transfer.table
    keep = table.omega > 0
    try:
        model = table_model(table.omega[keep], table.response[keep], transfer.text)
    except EngineError as exc:
        raise SessionError(f"--fit: {exc}: export the table itself (leave out --fit)") from None
    zeros, poles, gain = model.zeros, model.poles, model.gain
    num = np.real(gain * np.poly(zeros)) if zeros.size else np.array([gain])
    den = np.real(np.poly(poles)) if poles.size else np.array([1.0])
    return {
        "kind": "fitted",
        "text": transfer.text,
        "num": tuple(num.tolist()),
        "den": tuple(den.tolist()),
        "gain": gain,
        "zeros": tuple(zeros.tolist()),
        "poles": tuple(poles.tolist()),
        "residual": model.residual,
        "degree": model.degree,
    }
