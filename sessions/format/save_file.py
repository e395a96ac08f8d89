"""Writing a file so that nothing is lost or torn.

The bytes go to a temporary file beside the target (``.NAME.~HOST~PID~XXXX.tmp``),
are flushed to disk, and replace the target by a rename: a crash (even kill -9)
leaves the old file or the new one, never half of either.  A symlink is written
through (its real file is replaced) and the file's mode is kept.  Before a
save replaces a file, `refuse_overwrite` checks that it is not read-only and
has not changed on disk since it was read (`DiskStamp`), unless forced.

Temporary files of a killed save are swept by the next save; a sweep never
removes one that may still be in flight (another live process's, or any
younger than `STALE_AFTER`).  Every failure is an `OSError` the caller turns
into a `SessionError` (`describe` says which, e.g. "No space left on device
(ENOSPC)").
"""

from __future__ import annotations

import errno
import hashlib
import os
import re
import secrets
import socket
import stat
import time
from dataclasses import dataclass
from pathlib import Path

from sessions.errors import SessionError

STALE_AFTER = 3600.0  # s: a temporary file this old is a leftover, whoever made it
_HOST = re.sub(r"[^A-Za-z0-9_.-]", "_", socket.gethostname()) or "host"
_TAGGED = re.compile(r"\.~(?P<host>[^~]*)~(?P<pid>\d+)~[^~]*\.tmp$")


class OverwriteRefused(SessionError):
    """Saving would overwrite what it should not (a file changed on disk since it was
    loaded, or a read-only file): ask the user, then save again with ``force=True``."""


@dataclass(frozen=True)
class DiskStamp:
    """What a file on disk was when it was read or written: its real path, mtime, size, hash."""

    path: str
    mtime_ns: int
    size: int
    sha256: str


def real_path(path: Path) -> Path:
    """The file a path names, through symlinks (which need not exist yet)."""
    return Path(os.path.realpath(path))


def describe(exc: OSError) -> str:
    """An OS error in words and by name: 'No space left on device (ENOSPC)'."""
    words = exc.strerror or str(exc) or type(exc).__name__
    name = errno.errorcode.get(exc.errno) if exc.errno is not None else None
    return f"{words} ({name})" if name else words


def encoded(text: str) -> bytes:
    """The UTF-8 bytes of a text to write: a lone surrogate (a JSON file can hold "\\ud800")
    is written as its escape, never an error (every text a file gets goes through here)."""
    return text.encode("utf-8", errors="backslashreplace")


def printable(text: str) -> str:
    """``text`` with each lone surrogate written as its escape (for a library that takes
    only encodable text, such as matplotlib's fonts)."""
    return encoded(text).decode("utf-8")


def stamp_of(path: Path, data: bytes, st: os.stat_result) -> DiskStamp:
    """The stamp of ``data`` read from ``path`` whose open file's status was ``st``."""
    return DiskStamp(str(real_path(path)), st.st_mtime_ns, st.st_size, hashlib.sha256(data).hexdigest())


def refuse_overwrite(target: Path, loaded: DiskStamp | None, force: bool) -> None:
    """A `SessionError` when ``target`` is not a file; `OverwriteRefused` when replacing it
    would lose something: it is read-only, or it is the file ``loaded`` was read from and
    has changed since (``force``: replace it anyway)."""
    real = real_path(target)
    try:
        st = os.stat(real)
    except FileNotFoundError:
        return
    except OSError as exc:
        raise SessionError(f"{target}: cannot save: {describe(exc)}") from None
    if not stat.S_ISREG(st.st_mode):
        raise SessionError(f"{target}: cannot save: {'it is a folder' if stat.S_ISDIR(st.st_mode) else 'not a file'}")
    if read_only_system(real):
        raise SessionError(f"{target}: cannot save: the file system is read-only (EROFS); save elsewhere")
    if force:
        return
    if not st.st_mode & 0o222:
        raise OverwriteRefused(f"{target}: the file is read-only (mode {stat.S_IMODE(st.st_mode):04o}); not saved")
    if not os.access(real, os.W_OK):
        raise OverwriteRefused(
            f"{target}: this user may not write the file (mode {stat.S_IMODE(st.st_mode):04o}, "
            f"owner uid {st.st_uid}); not saved"
        )
    if loaded is not None and loaded.path == str(real) and _changed(real, st, loaded):
        raise OverwriteRefused(
            f"{target}: changed on disk since it was loaded (another program or session saved it); not saved"
        )


def check_output(target: Path, inputs: dict[Path, str], force: bool, option: str = "--out") -> None:
    """The one check of a command's output file, made before any work: a `SessionError`
    when writing ``target`` would destroy something.  It is one of the command's
    ``inputs`` (path -> what it is, e.g. "the session"; the same file by real path or
    inode), it is not a regular file (a folder, FIFO, device or socket: an atomic rename
    would replace it), or it exists and ``force`` is not given.  Messages name ``option``
    (empty: the target alone)."""
    where = f"{option} {target}" if option else str(target)
    real = real_path(target)
    try:
        st: os.stat_result | None = os.stat(real)
    except (FileNotFoundError, NotADirectoryError):
        st = None  # nothing there (its folder's absence is the writer's to say)
    except OSError as exc:
        raise SessionError(f"{where}: cannot write: {describe(exc)}") from None
    for source, what in inputs.items():
        if _same_file(real, st, source):
            raise SessionError(f"{where}: is {what}, an input of the command; write elsewhere")
    if st is None:
        return
    if not stat.S_ISREG(st.st_mode):
        raise SessionError(f"{where}: {_kind_of(st.st_mode)}, not a regular file; write to a file")
    if not force:
        raise SessionError(f"{where}: exists (--force replaces it)")


def _same_file(real: Path, st: os.stat_result | None, source: Path) -> bool:
    if real == real_path(source):
        return True
    try:
        other = os.stat(source)
    except OSError:
        return False
    return st is not None and (st.st_dev, st.st_ino) == (other.st_dev, other.st_ino)


def _kind_of(mode: int) -> str:
    if stat.S_ISDIR(mode):
        return "a folder"
    if stat.S_ISFIFO(mode):
        return "a FIFO"
    if stat.S_ISCHR(mode) or stat.S_ISBLK(mode):
        return "a device"
    return "a special file"


def read_only_system(path: Path) -> bool:
    """Whether ``path`` lies on a file system mounted read-only (no save there can succeed)."""
    try:
        return bool(os.statvfs(path).f_flag & os.ST_RDONLY)
    except (OSError, AttributeError):
        return False


def _changed(real: Path, st: os.stat_result, loaded: DiskStamp) -> bool:
    if (st.st_mtime_ns, st.st_size) == (loaded.mtime_ns, loaded.size):
        return False
    try:
        return hashlib.sha256(real.read_bytes()).hexdigest() != loaded.sha256  # touched is not changed
    except OSError:
        return True


def check_writable(target: Path, force: bool = False) -> None:
    """A `SessionError` now, before any work, when ``target`` could not be saved: its
    folder is missing or not writable, it is a folder, or it is read-only (unless ``force``)."""
    real = real_path(target)
    if not real.parent.is_dir():
        raise SessionError(f"{target}: cannot save: the folder {real.parent} does not exist")
    refuse_overwrite(target, None, force)
    try:
        fd, probe = _temporary(real)
        os.close(fd)
        os.unlink(probe)
    except OSError as exc:
        raise SessionError(
            f"{target}: cannot save: the folder {real.parent} is not writable ({describe(exc)})"
        ) from None


def _temporary(real: Path) -> tuple[int, str]:
    """A new temporary file beside ``real`` (mode 0666 less the umask), named for this process."""
    for _ in range(100):
        name = real.parent / f".{real.name}.~{_HOST}~{os.getpid()}~{secrets.token_hex(4)}.tmp"
        try:
            return os.open(name, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666), str(name)
        except FileExistsError:
            continue
    raise FileExistsError(errno.EEXIST, "no free temporary file name", str(real.parent))


def mode_of(path: Path) -> int | None:
    """The permission bits of an existing file (None: there is none)."""
    try:
        return stat.S_IMODE(os.stat(path).st_mode)
    except OSError:
        return None


def write_atomic(path: Path, data: bytes | str, mode: int | None = None) -> DiskStamp:
    """Replace the real file of ``path`` by ``data`` (a rename of a flushed temporary
    file); ``mode``: its permission bits (None: a new file's).  Raises `OSError`.
    A text is written as UTF-8 whatever it holds (`encoded`)."""
    data = encoded(data) if isinstance(data, str) else data
    real = real_path(path)
    fd, tmp = _temporary(real)
    try:
        try:
            view = memoryview(data)
            while view:
                view = view[os.write(fd, view) :]
            if mode is not None:
                os.fchmod(fd, mode)
            os.fsync(fd)
            st = os.fstat(fd)
        finally:
            os.close(fd)
        os.replace(tmp, real)
    except BaseException:
        _remove(tmp)
        raise
    _sync_folder(real.parent)
    return DiskStamp(str(real), st.st_mtime_ns, st.st_size, hashlib.sha256(data).hexdigest())


def back_up(path: Path, backup: Path) -> None:
    """Copy the real file of ``path`` (when there is one) to ``backup``, atomically, mode and all."""
    real = real_path(path)
    try:
        with open(real, "rb") as fh:
            data = fh.read()
            mode = stat.S_IMODE(os.fstat(fh.fileno()).st_mode)
    except FileNotFoundError:
        return
    write_atomic(backup, data, mode)


def sweep_stale(real: Path, now: float | None = None) -> None:
    """Remove temporary files that saves of ``real`` (and of its .bak and .autosave) left
    behind: a dead process's on this host, or anyone's older than `STALE_AFTER`; never ours."""
    now = time.time() if now is None else now
    for tmp in real.parent.glob(f".{glob_escape(real.name)}.*tmp"):
        tag = _TAGGED.search(tmp.name)
        if tag and tag["host"] == _HOST and int(tag["pid"]) == os.getpid():
            continue
        try:
            old = now - tmp.lstat().st_mtime > STALE_AFTER
        except OSError:
            continue
        if old or (tag and tag["host"] == _HOST and not _alive(int(tag["pid"]))):
            _remove(str(tmp))


def glob_escape(name: str) -> str:
    """A file name as a glob pattern matching only itself."""
    return re.sub(r"([*?\[])", r"[\1]", name)


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (PermissionError, OverflowError, ValueError):
        return True
    return True


def remove_quietly(path: Path) -> None:
    """Delete a file if it is there and can be deleted (a cleanup never fails a save)."""
    _remove(str(path))


def _remove(path: str) -> None:
    try:
        os.unlink(path)
    except OSError:
        pass


def _sync_folder(folder: Path) -> None:
    try:
        fd = os.open(folder, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)
