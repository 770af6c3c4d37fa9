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


def require_int(source, field, value, minimum: int, meaning: str = "",
                maximum: int | None = None):
    """``value`` as an int if it is an integer in [``minimum``, ``maximum``] (no upper
    limit when None), else InputError."""
    import numbers
    if isinstance(value, bool) or not isinstance(value, numbers.Integral) or value < minimum \
            or (maximum is not None and value > maximum):
        allowed = f">= {minimum}" if maximum is None else f"in [{minimum}, {maximum:.0e}]" \
            if maximum >= 10 ** 6 else f"in [{minimum}, {maximum}]"
        raise InputError(source, field, f"must be an integer {allowed}"
                         + (f" ({meaning})" if meaning else ""), got=value)
    return int(value)


def require_array(source, field, value, shape: tuple, meaning: str = ""):
    """``value`` as a float array of ``shape`` (None entries: any length) with finite
    entries, else InputError naming the expected shape (a door check: a wrong shape
    otherwise surfaces as a numpy broadcast error deep inside, or draws the wrong thing)."""
    import numpy as np
    try:
        a = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        a = None
    want = "(" + ", ".join("k" if s is None else str(s) for s in shape) + \
        ("," if len(shape) == 1 else "") + ")"
    what = f"must be a finite float array of shape {want}" + (f" ({meaning})" if meaning else "")
    if a is None or a.ndim != len(shape) or any(s is not None and s != g
                                                 for s, g in zip(shape, a.shape)):
        raise InputError(source, field, what, got=None if a is None else a.shape)
    if not np.all(np.isfinite(a)):
        raise InputError(source, field, what + "; found NaN or inf")
    return a
