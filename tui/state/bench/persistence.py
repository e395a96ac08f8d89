"""The Workbench's file: whether the session has unsaved changes, whether it still needs a
name of the user's (a new session), saving (in place or as another file: Save As), the
autosave beside it, and reopening a file or its newer autosave.  Every write is atomic
(`sessions.store`: a temporary file renamed over the target, the previous one kept as
``.bak``)."""

from __future__ import annotations

from pathlib import Path

from sessions.store import (
    AUTOSAVE_INTERVAL,
    Session,
    autosave_path,
    load_autosave,
    load_session,
    save_session,
    write_autosave,
)


class SessionFile:
    """Where one open session is kept, and whether it is kept there as it is now."""

    def __init__(self, session: Session, untitled: bool = False) -> None:
        self._session = session
        self.dirty = False
        self.untitled = untitled  # a new session, not yet saved under a name of the user's: its first save asks one

    def mark_changed(self) -> None:
        """The session changed since it was last saved."""
        self.dirty = True

    def iteration_kept(self) -> None:
        """A run's iteration was kept: unsaved, and autosaved at most every AUTOSAVE_INTERVAL
        in the background (the whole session is written each time)."""
        self.dirty = True
        write_autosave(self._session, at_most_every=AUTOSAVE_INTERVAL, wait=False)

    @property
    def needs_name(self) -> bool:
        """Whether the next save asks where (no file yet, or a new session's provisional one)."""
        return self._session.path is None or self.untitled

    def save(self, path: str | Path | None = None, force: bool = False) -> Path:
        """Save in place, or to ``path`` (Save As); ``force``: over a file changed on disk since
        it was loaded, or a read-only one (`OverwriteRefused` otherwise).  Where it went."""
        target = save_session(self._session, path, force=force)
        self.dirty = False
        self.untitled = self.untitled and path is None
        return target

    def autosave(self, throttled: bool = False, wait: bool = True) -> str:
        """Write the autosave of unsaved changes (``throttled``: at most every
        AUTOSAVE_INTERVAL, as runs do; ``wait``: for the write, else it goes on in the
        background, in order); says where, or why it could not."""
        if not self.dirty:
            return "nothing unsaved"
        if self._session.path is None:
            return "no autosave (the session has no file yet)"
        write_autosave(self._session, at_most_every=AUTOSAVE_INTERVAL if throttled else 0.0, wait=wait)
        if not wait:
            return f"autosaving to {autosave_path(self._session.path).name}"
        if self._session.autosave_warning:
            return f"the autosave failed: {self._session.autosave_warning}"
        return f"autosaved to {autosave_path(self._session.path).name}"


def reopen(path: Path, keep_path: Path | None = None, allow_outside_tables: bool = False) -> Session:
    """The session of ``path``; with ``keep_path`` another file (its newer autosave), recovered
    to be saved to ``keep_path`` (`sessions.store.load_autosave`)."""
    if keep_path is not None and path != keep_path:
        return load_autosave(keep_path, allow_outside_tables)
    return load_session(path, allow_outside_tables)
