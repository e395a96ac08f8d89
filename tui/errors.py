"""Errors of the command line."""


class CliError(Exception):
    """Bad input on the command line: printed as one line, exit status 2."""
