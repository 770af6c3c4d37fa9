"""Ctrl-C while a kernel runs: a request the engine honours between kernel calls.

A SIGINT that arrives while numba code runs raises KeyboardInterrupt inside numba's
dispatcher, which then fails with a SystemError chain. Within :func:`deferred_sigint`
(main thread only) SIGINT only sets a flag; the protocol checks it after every kernel
call, saves its checkpoint and raises :class:`Interrupted`, which the CLI reports in
one line with exit code 130.
"""
from __future__ import annotations

import contextlib
import signal
import threading


class Interrupted(KeyboardInterrupt):
    """Ctrl-C honoured at a safe point; the message says where the run resumes from."""


class InterruptFlag:
    """Whether an interrupt was requested (never, unless set by :func:`deferred_sigint`)."""

    def __init__(self):
        self.requested = False

    def check(self, message: str = "") -> None:
        """Raise :class:`Interrupted` (with ``message``) if an interrupt was requested."""
        if self.requested:
            raise Interrupted(message)


@contextlib.contextmanager
def deferred_sigint():
    """Yield an :class:`InterruptFlag` that SIGINT sets instead of raising (restored on
    exit). Outside the main thread signals cannot be handled: the flag stays unset."""
    flag = InterruptFlag()
    if threading.current_thread() is not threading.main_thread():
        yield flag
        return

    def handler(signum, frame):
        flag.requested = True

    old = signal.signal(signal.SIGINT, handler)
    try:
        yield flag
    finally:
        signal.signal(signal.SIGINT, old)
