"""The matrices of a state space from a file: a numpy .npz archive (arrays A, B, C
and optionally D; np.load with allow_pickle=False: nothing is unpickled) or a
.json object (keys A, B, C and optionally D: A a list of rows, B and C lists of
numbers, D a number).  Only a regular file of at most `MAX_MATRIX_BYTES`, read
with a bounded read (`sessions.format.reading`); every failure is a
`SessionError` naming the file (and the JSON path or option it came from).
The shapes are checked where the block is made (`engine.model.state_space`).
"""

from __future__ import annotations

import io
import json
from pathlib import Path

import numpy as np

from sessions.errors import SessionError, in_words
from sessions.format.reading import decoded, read_regular

MAX_MATRIX_BYTES = 20 * 2**20  # a state-space file (400 states take 1.3 MB in .npz, about 4 MB in .json)
NAMES = ("A", "B", "C", "D")
SUFFIXES = (".npz", ".json")


def read_matrices(file: Path, where: str) -> dict[str, np.ndarray]:
    """A, B, C and D (0 when the file has none) of the state space in ``file``; errors are
    prefixed with ``where`` (a JSON path, or the option that named the file)."""
    suffix = file.suffix.lower()
    if suffix not in SUFFIXES:
        raise SessionError(f"{where}: {file.name}: a state space is read from a .npz or a .json file")
    try:
        data = read_regular(file, MAX_MATRIX_BYTES)[0]
    except SessionError as exc:
        raise SessionError(f"{where}: {exc}") from None
    arrays = _npz(data, file, where) if suffix == ".npz" else _json(data, file, where)
    missing = [name for name in NAMES[:3] if name not in arrays]
    unknown = sorted(set(arrays) - set(NAMES))
    if missing or unknown:
        held = ", ".join(sorted(arrays)) or "nothing"
        raise SessionError(f"{where}: {file.name} holds {held}; a state space is A, B, C and optionally D")
    return {"D": np.zeros(()), **arrays}


def _npz(data: bytes, file: Path, where: str) -> dict[str, np.ndarray]:
    try:
        with np.load(io.BytesIO(data), allow_pickle=False) as archive:
            arrays = {name: archive[name] for name in archive.files}
    except Exception as exc:  # noqa: BLE001 - any reader failure on a malformed file (BadZipFile, ValueError...)
        raise SessionError(f"{where}: {file.name}: cannot read: {in_words(exc)}") from None
    for name, array in arrays.items():
        if array.dtype.kind not in "biuf":
            raise SessionError(f"{where}: {file.name}: {name} is not an array of real numbers ({array.dtype})")
    return arrays


def _json(data: bytes, file: Path, where: str) -> dict[str, np.ndarray]:
    try:
        value = json.loads(decoded(data, file), parse_constant=_no_constant)
    except (SessionError, ValueError) as exc:
        raise SessionError(f"{where}: {file.name}: not JSON ({exc})") from None
    if not isinstance(value, dict):
        raise SessionError(f"{where}: {file.name}: expected an object with keys A, B, C and optionally D")
    arrays = {}
    for name, item in value.items():
        try:
            arrays[name] = np.asarray(item, dtype=float)
        except (TypeError, ValueError, OverflowError):
            raise SessionError(f"{where}: {file.name}: {name} is not a matrix of numbers") from None
    return arrays


def _no_constant(name: str) -> float:
    raise ValueError(f"{name} is not a finite number")
