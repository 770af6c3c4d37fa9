"""Errors that reach the user as one clear line (never a numba traceback)."""


class ForcespaceError(Exception):
    """Base class of every error forcespace reports to a user.

    ``exit_code`` and ``kind``: what the command line exits with and the word it prints
    before the message (a plug-in's own errors set theirs)."""

    exit_code = 2
    kind = "error"


class InputError(ForcespaceError):
    """Bad input: names the file, the field and what is allowed.

    ``InputError("inputs/a.toml", "disks.n", "must be an integer >= 1", got=0)``
    reads ``inputs/a.toml: disks.n = 0: must be an integer >= 1``.
    """

    def __init__(self, source, field, allowed, got=None):
        self.source, self.field, self.allowed, self.got = str(source), field, allowed, got
        value = "" if got is None else f" = {got!r}"
        super().__init__(f"{self.source}: {field}{value}: {allowed}")

    def __reduce__(self):
        """Picklable with its fields (a task's error crosses from a pool worker intact;
        the default would call __init__ with the message alone and fail)."""
        return (type(self), (self.source, self.field, self.allowed, self.got))


class NumericalError(ForcespaceError):
    """A computation produced a non-finite value or failed to converge where it must."""

    exit_code = 3
    kind = "not converged"


def require_int(source, field, value, minimum: int, meaning: str = ""):
    """``value`` as an int if it is an integer >= ``minimum``, else InputError."""
    import numbers
    if isinstance(value, bool) or not isinstance(value, numbers.Integral) or value < minimum:
        raise InputError(source, field, f"must be an integer >= {minimum}"
                         + (f" ({meaning})" if meaning else ""), got=value)
    return int(value)
