"""Reading a file a user names (a session, its autosave, a CSV table): a regular
file only, never more than a bound, decoded as UTF-8 with or without a BOM.

A device (``/dev/zero``), a FIFO, a folder or a symlink loop is refused at
once, without a read that fills the memory and without an open that blocks;
every failure is a `SessionError` naming the file and the reason."""

from __future__ import annotations

import os
import stat
from pathlib import Path

from sessions.errors import SessionError
from sessions.format.save_file import describe

_KINDS = (
    (stat.S_ISDIR, "a folder"),
    (stat.S_ISFIFO, "a FIFO"),
    (stat.S_ISCHR, "a character device"),
    (stat.S_ISBLK, "a block device"),
    (stat.S_ISSOCK, "a socket"),
)


def read_regular(file: Path, limit: int) -> tuple[bytes, os.stat_result]:
    """The bytes of the regular file ``file`` (at most ``limit`` of them; never more is
    read) and its status, taken from the same open file."""
    try:
        fd = os.open(file, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0))  # a FIFO must not block the open
    except (OSError, ValueError) as exc:
        raise SessionError(f"cannot read {file}: {_reason(exc)}") from None
    info = os.fstat(fd)
    try:
        _check_kind(info, file, limit)
    except SessionError:
        os.close(fd)
        raise
    with open(fd, "rb") as fh:
        try:
            data = fh.read(limit + 1)
        except OSError as exc:
            raise SessionError(f"cannot read {file}: {describe(exc)}") from None
    if len(data) > limit:
        raise SessionError(f"{file.name} has more than {limit} bytes (at most {limit})")
    return data, info


def decoded(data: bytes, file: Path) -> str:
    """UTF-8 text, a byte order mark (BOM) dropped; else a `SessionError` naming the byte."""
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise SessionError(f"{file.name}: not UTF-8 text (byte {exc.start})") from None


def _check_kind(info: os.stat_result, file: Path, limit: int) -> None:
    if not stat.S_ISREG(info.st_mode):
        kind = next((name for test, name in _KINDS if test(info.st_mode)), "neither")
        raise SessionError(f"{file} is not a regular file (it is {kind})")
    if info.st_size > limit:
        raise SessionError(f"{file.name} has {info.st_size} bytes; at most {limit}")


def _reason(exc: OSError | ValueError) -> str:
    if isinstance(exc, ValueError):  # a NUL in the name
        return "not a file name"
    return describe(exc)


def resolved(file: Path) -> Path:
    """``file`` through its symlinks, absolute; a symlink loop (pathlib's RuntimeError)
    or an unreadable link is a `SessionError` naming the file."""
    try:
        return file.resolve()
    except RuntimeError:
        raise SessionError(f"cannot read {file}: a symlink loop (a link that leads back to itself)") from None
    except OSError as exc:
        raise SessionError(f"cannot read {file}: {describe(exc)}") from None
