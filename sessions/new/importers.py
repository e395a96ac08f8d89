"""Plants from MATLAB .mat files (scipy.io.loadmat) and numpy .npz archives
(np.load with allow_pickle=False: nothing is unpickled, no code runs).

Documented array names, the same in both formats (the first set found wins):

* ``num``, ``den``: transfer-function coefficients, descending powers of s;
* ``A``, ``B``, ``C``, ``D``: a SISO state space (D optional, 0), kept as a
  state-space block with its matrices inline;
* ``freq``, ``resp``: a frequency response (FRD): frequencies (rad/s, or Hz
  with ``unit`` = "hz") and complex responses (or ``resp_real`` and
  ``resp_imag``); it becomes a CSV table written beside the session.
"""

from __future__ import annotations

import csv
import io
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from engine.errors import EngineError
from sessions.errors import SessionError, in_words
from sessions.new.templates import corner_grid

MAX_ORDER = 64  # a coefficient list of a polynomial block holds at most 65 numbers (sessions.format.limits)


@dataclass(frozen=True)
class ImportedPlant:
    """A plant for `sessions.new.templates.new_session`: an expression, or a table transfer
    with its grid and the CSV text to write as ``csv_name`` beside the session."""

    plant: str | dict
    description: str
    grid: dict | None = None
    csv_name: str | None = None
    csv_text: str = field(default="", repr=False)


def read_plant_file(path: str | Path, session: str | Path) -> ImportedPlant:
    """The plant stored in ``path`` (.mat or .npz); a table is named after ``session``."""
    path = Path(path)
    arrays = _arrays(path)
    where = f"--plant-file {path}"
    if "num" in arrays and "den" in arrays:
        return _rational(arrays["num"], arrays["den"], where, "num/den")
    if all(k in arrays for k in ("A", "B", "C")):
        return _state_space(arrays, where)
    if "freq" in arrays and ("resp" in arrays or ("resp_real" in arrays and "resp_imag" in arrays)):
        return _frd(arrays, where, Path(session))
    raise SessionError(
        f"{where}: holds {', '.join(sorted(arrays)) or 'no arrays'}; expected num and den, "
        "A, B, C (and D), or freq and resp"
    )


def _arrays(path: Path) -> dict[str, np.ndarray]:
    """The named numeric arrays of a .mat or .npz file (a clear error for anything else)."""
    where = f"--plant-file {path}"
    if not path.is_file():
        raise SessionError(f"{where}: no such file")
    try:
        if path.suffix.lower() == ".mat":
            from scipy.io import loadmat

            raw = {k: v for k, v in loadmat(str(path)).items() if not k.startswith("__")}
        elif path.suffix.lower() == ".npz":
            with np.load(path, allow_pickle=False) as data:
                raw = {k: data[k] for k in data.files}
        else:
            raise SessionError(f"{where}: expected a .mat or .npz file")
    except SessionError:
        raise
    except Exception as exc:  # noqa: BLE001 - a reader failing on a malformed file (IndexError, MatReadError...)
        raise SessionError(f"{where}: cannot read: {in_words(exc)}") from None
    return {k: _numeric(v, f"{where}: {k}") for k, v in raw.items()}


def _numeric(value, where: str) -> np.ndarray:
    array = np.asarray(value)
    if array.dtype.kind == "U" or array.dtype.kind == "S":
        return np.asarray(str(array.squeeze()) if array.size else "")
    if array.dtype.kind not in "biufc":
        raise SessionError(f"{where}: not a numeric array ({array.dtype})")
    return array


def _finite_vector(value: np.ndarray, where: str) -> np.ndarray:
    v = np.atleast_1d(np.squeeze(value))
    if v.ndim != 1 or v.size == 0 or v.dtype.kind not in "biufc" or not np.all(np.isfinite(v)):
        raise SessionError(f"{where}: must be a non-empty vector of finite numbers")
    return v


def _real_vector(value: np.ndarray, where: str) -> np.ndarray:
    v = _finite_vector(value, where)
    if v.dtype.kind == "c":
        if np.any(v.imag != 0):
            raise SessionError(f"{where}: coefficients must be real")
        v = v.real
    return v.astype(float)


def _rational(num, den, where: str, what: str) -> ImportedPlant:
    n = np.trim_zeros(_real_vector(num, f"{where}: num"), "f")
    d = np.trim_zeros(_real_vector(den, f"{where}: den"), "f")
    if d.size == 0:
        raise SessionError(f"{where}: den is zero")
    if n.size == 0:
        raise SessionError(f"{where}: num is zero (no loop to design)")
    if max(n.size, d.size) - 1 > MAX_ORDER:
        raise SessionError(f"{where}: degree {max(n.size, d.size) - 1} is beyond {MAX_ORDER}")
    text = f"({_polynomial(n)})/({_polynomial(d)})"
    return ImportedPlant(text, f"{what} from {where.removeprefix('--plant-file ')}")


def _polynomial(c: np.ndarray) -> str:
    """Descending coefficients as an expression in s, each with its full-precision repr."""
    top = c.size - 1
    return " + ".join(f"{float(x)!r}*s**{top - k}" if top - k else f"{float(x)!r}" for k, x in enumerate(c))


def _state_space(arrays: dict, where: str) -> ImportedPlant:
    """A state-space block with the matrices inline (never multiplied out into a polynomial,
    which overflows at high order), and a grid two decades beyond its poles and zeros."""
    from engine.model.blocks import StateSpaceTransfer  # on use: `loopcraft new --help` stays light

    A = np.atleast_2d(np.asarray(arrays["A"]))  # as stored: a complex matrix is refused by the block, not cast
    B = np.asarray(arrays["B"]).reshape(A.shape[0], -1) if A.size else np.zeros((0, 1))
    C = np.asarray(arrays["C"]).reshape(-1, A.shape[0]) if A.size else np.zeros((1, 0))
    D = np.atleast_2d(np.asarray(arrays.get("D", np.zeros((1, 1)))))
    if A.shape[0] != A.shape[1] or B.shape[1] != 1 or C.shape[0] != 1 or D.shape != (1, 1):
        raise SessionError(
            f"{where}: A, B, C, D must be a SISO state space (A n x n, B n x 1, C 1 x n, D 1 x 1); "
            f"got {A.shape}, {B.shape}, {C.shape}, {D.shape}"
        )
    try:
        plant = StateSpaceTransfer(A, B, C, D, where.removeprefix("--plant-file "))
        form = plant.form
    except EngineError as exc:
        raise SessionError(f"{where}: {exc}") from None
    if form.gain == 0:
        raise SessionError(f"{where}: C (sI - A)^-1 B + D is 0 at every frequency (no loop to design)")
    m = plant.matrices
    block = {"kind": "state_space", "A": m.A.tolist(), "B": m.B.tolist(), "C": m.C.tolist(), "D": m.D}
    grid = corner_grid(np.concatenate([form.zeros, form.poles]))
    return ImportedPlant(block, f"state space of order {plant.order} (A, B, C, D) from {plant.source}", grid)


def _frd(arrays: dict, where: str, session: Path) -> ImportedPlant:
    freq = _real_vector(arrays["freq"], f"{where}: freq")
    if "resp" in arrays:
        resp = _finite_vector(arrays["resp"], f"{where}: resp").astype(complex)
    else:
        resp = _real_vector(arrays["resp_real"], f"{where}: resp_real") + 1j * _real_vector(
            arrays["resp_imag"], f"{where}: resp_imag"
        )
    unit = str(arrays.get("unit", np.asarray("rad/s"))).strip().lower() or "rad/s"
    if unit not in ("rad/s", "hz"):
        raise SessionError(f"{where}: unit must be 'rad/s' or 'hz', not {unit!r}")
    if freq.size != resp.size or freq.size < 2 or np.any(np.diff(freq) <= 0) or freq[0] < 0:
        raise SessionError(f"{where}: freq and resp need the same length (at least 2), freq increasing and >= 0")
    out = io.StringIO()
    writer = csv.writer(out, lineterminator="\n")
    writer.writerow(["frequency", "real", "imag"])
    writer.writerows([repr(float(f)), repr(float(r.real)), repr(float(r.imag))] for f, r in zip(freq, resp))
    name = f"{session.stem}_plant.csv"
    table = {
        "kind": "table",
        "table": {"csv": name, "columns": ["frequency", "real", "imag"], "form": "cartesian", "unit": unit},
    }
    positive = freq[freq > 0]
    grid = {"unit": unit, "start": float(positive[0]), "stop": float(freq[-1]), "points": 400, "spacing": "log"}
    return ImportedPlant(
        table,
        f"frequency response ({freq.size} points) from {where.removeprefix('--plant-file ')}",
        grid,
        name,
        out.getvalue(),
    )
