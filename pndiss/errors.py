"""Errors the user can fix: one line on stderr, exit 2."""


class UsageError(Exception):
    """Bad arguments or input the user can fix."""
