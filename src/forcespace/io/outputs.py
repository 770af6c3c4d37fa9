"""Output paths: checked before any work, written under a lock, never destroying user data.

Every command that writes checks its outputs first (:func:`check_output_file`,
:func:`check_output_dir`), so a bad path fails in a second, not after an hour
of simulation. Writers hold :func:`output_lock` (a non-blocking ``flock`` on a
hidden ``.NAME.lock`` beside the target): a second process writing the same
file is refused with a clear error instead of interleaving. Under the lock,
temporary files of earlier runs that were killed (``.NAME.*.tmp``, the pattern
of :func:`forcespace.h5io.atomic_path`) are removed. Run directories that
forcespace creates carry a marker file; a directory without it is never
replaced or deleted.
"""
from __future__ import annotations

import contextlib
import errno
import fcntl
import os
import stat
from pathlib import Path

from ..errors import InputError

RUN_DIR_MARKER = ".forcespace-run"


def _parent_writable(p: Path, field: str) -> None:
    parent = p.parent if str(p.parent) else Path(".")
    try:
        parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise InputError(p, field, f"its directory cannot be created ({exc.strerror})") from None
    if not parent.is_dir():
        raise InputError(p, field, f"{parent} is not a directory")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise InputError(p, field, f"its directory {parent} is not writable")


def check_output_file(path, inputs=(), field: str = "-o/--output") -> Path:
    """Refuse an output path before any work: it must not be an input, nor an
    existing non-regular file (directory, symlink, device, fifo); its directory
    must exist or be creatable, and be writable. Returns the path."""
    p = Path(path)
    if p.name in ("", ".", "..") or str(path).endswith(os.sep):
        raise InputError(p, field, "must name a file, not a directory")
    for i in inputs:
        if i is None:
            continue
        q = Path(i)
        same = q.exists() and p.exists() and os.path.samefile(p, q)
        if same or p.resolve() == q.resolve():
            raise InputError(p, field, f"is also an input ({q}); choose another output file")
    if p.is_symlink():
        raise InputError(p, field, "is a symbolic link; give the path of a regular file")
    if p.exists():
        mode = p.stat().st_mode
        if not stat.S_ISREG(mode):
            kind = "a directory" if stat.S_ISDIR(mode) else "not a regular file (device, fifo "\
                "or socket)"
            raise InputError(p, field, f"exists and is {kind}; forcespace replaces only "
                             "regular files")
    _parent_writable(p, field)
    return p


def check_output_dir(path, field: str = "-o/--output") -> Path:
    """Refuse a run directory forcespace may not replace: an existing non-directory,
    or a non-empty directory without forcespace's marker file. Returns the path."""
    d = Path(path)
    if d.is_symlink() or (d.exists() and not d.is_dir()):
        raise InputError(d, field, "exists and is not a directory")
    if d.is_dir() and any(d.iterdir()) and not (d / RUN_DIR_MARKER).is_file():
        raise InputError(d, field, "is a non-empty directory that forcespace did not create; "
                         "choose a new or empty directory (nothing was changed)")
    _parent_writable(d, field)
    return d


def mark_run_dir(path) -> None:
    """Mark a directory as created by forcespace (so a later export may replace it)."""
    (Path(path) / RUN_DIR_MARKER).write_text("created by forcespace; safe to replace\n")


def clean_stale_temps(path) -> list[Path]:
    """Remove forcespace temp files of ``path`` left by killed runs (call under the lock)."""
    p = Path(path)
    gone = []
    for t in p.parent.glob(f".{p.name}.*.tmp"):
        with contextlib.suppress(OSError):
            t.unlink()
            gone.append(t)
    return gone


@contextlib.contextmanager
def output_lock(path):
    """Hold an exclusive, non-blocking lock on ``path`` for writing; stale temp files
    of ``path`` are removed once it is held. InputError if another process holds it."""
    p = Path(path)
    _parent_writable(p, "-o/--output")
    lock = p.parent / f".{p.name}.lock"
    fd = os.open(lock, os.O_RDWR | os.O_CREAT, 0o666)
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError as exc:
            if exc.errno in (errno.EWOULDBLOCK, errno.EAGAIN, errno.EACCES):
                raise InputError(p, "(lock)", "is being written by another forcespace process; "
                                 "wait for it or choose another output") from None
            raise
        clean_stale_temps(p)
        yield p
    finally:
        os.close(fd)          # releases the lock
