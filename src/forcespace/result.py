"""The one convention of forcespace's compute objects (after freud and scipy).

Parameters go to the constructor, data to ``compute(data)``, which returns the
object itself; results are read-only properties documented with shape and unit.
Reading a result before ``compute`` raises ``AttributeError``. Whether the
computation finished is reported, not raised, as by scipy's ``OptimizeResult``:
``success`` (bool), ``status`` (one of :data:`STATUS`) and ``message`` (one
line). Results that a failed computation did not reach raise ``AttributeError``
naming the failure; the command line turns ``success = False`` into exit code 3.
"""
from __future__ import annotations

STATUS = {
    0: "finished",
    1: "stopped at its cap (time, samples or iterations) before its target",
    2: "a numerical method failed",
}


class Computed:
    """Base of the compute objects: stores results and the outcome of ``compute``."""

    _results: dict | None = None
    _status: int = 0
    _message: str = ""

    def _start(self) -> None:
        """Forget earlier results (called at the start of ``compute``)."""
        self._results, self._status, self._message = {}, 0, ""

    def _finish(self, status: int = 0, message: str = "") -> None:
        self._status, self._message = int(status), message or STATUS[int(status)]

    def _get(self, name: str):
        cls = type(self).__name__
        if self._results is None:
            raise AttributeError(f"{cls}.{name}: call compute() first")
        if name not in self._results:
            raise AttributeError(f"{cls}.{name} is not available: {self._message}")
        return self._results[name]

    @property
    def computed(self) -> bool:
        """Whether ``compute`` has run."""
        return self._results is not None

    @property
    def success(self) -> bool:
        """``compute`` finished (status 0)."""
        self._get_outcome()
        return self._status == 0

    @property
    def status(self) -> int:
        """0 finished, 1 stopped at a cap, 2 a numerical method failed (:data:`STATUS`)."""
        self._get_outcome()
        return self._status

    @property
    def message(self) -> str:
        """One line saying how ``compute`` ended."""
        self._get_outcome()
        return self._message

    def _get_outcome(self) -> None:
        if self._results is None:
            raise AttributeError(f"{type(self).__name__}: call compute() first")
