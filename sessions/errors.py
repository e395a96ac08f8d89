"""The one error type session code raises on bad input."""


class SessionError(ValueError):
    """A session cannot be read, built, saved or replayed; the message says where and why."""
