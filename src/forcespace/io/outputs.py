"""Output paths: checked before any work, written under a lock, never destroying user data.

Every command that writes checks its outputs first (:func:`check_output_file`,
:func:`check_output_dir`), so a bad path fails in a second, not after an hour
of simulation. Writers hold :func:`output_lock` (a non-blocking lock, :func:`file_lock`,
on a hidden ``.NAME.lock`` beside the target): a second process writing the same
file is refused with a clear error instead of interleaving. Under the lock,
temporary files of earlier runs that were killed (``.NAME.*.tmp``, the pattern
of :func:`forcespace.io.h5.atomic_path`) are removed.

Output directories (viewer files, DEM run directories) follow one policy
(:func:`check_output_dir`, :func:`replace_run_dir`): forcespace records in a
marker file (``.forcespace-run``) every entry it wrote there; a directory is
replaced only when everything in it is recorded (a file a user added keeps it, and
names itself in the refusal), and never when it is the working directory or holds it.

Locks are `filelock <https://py-filelock.readthedocs.io>`_ locks (``flock`` on POSIX,
``msvcrt`` on Windows); the lock file is removed when the lock is released, so a
finished run leaves none behind.
"""
from __future__ import annotations

import contextlib
import os
import re
import secrets
import shutil
import stat
from pathlib import Path

from ..errors import InputError
from .h5 import write_refused

RUN_DIR_MARKER = ".forcespace-run"


NAME_MARGIN = 32     # characters forcespace adds to an output's name for the files beside
                     # it: .NAME.lock, .NAME.<8 hex>.tmp, NAME.checkpoint.h5 and its own


def check_name_length(path, field: str = "-o/--output") -> None:
    """InputError unless the filesystem takes ``path`` and the files forcespace names
    after it: its name at most NAME_MAX - NAME_MARGIN characters (NAME_MAX, usually 255,
    read from the filesystem), every folder's at most NAME_MAX, the whole absolute path
    at most PATH_MAX - 2 NAME_MARGIN."""
    p = Path(os.path.abspath(path))
    known = next((q for q in (p, *p.parents) if _exists(q)), Path(p.anchor or "/"))
    try:
        name_max = os.pathconf(known, "PC_NAME_MAX")
        path_max = os.pathconf(known, "PC_PATH_MAX")
    except (OSError, ValueError, AttributeError):
        name_max, path_max = 255, 4096
    long = [part for part in p.parts[1:-1] if len(part.encode()) > name_max]
    if long:
        raise InputError(path, field, f"has a folder name of {len(long[0].encode())} bytes; "
                         f"the filesystem takes at most {name_max}")
    if len(p.name.encode()) > name_max - NAME_MARGIN:
        raise InputError(path, field, f"has a name of {len(p.name.encode())} bytes; at most "
                         f"{name_max - NAME_MARGIN} here (the filesystem takes {name_max}, and "
                         "forcespace names lock and temporary files after it)")
    if len(str(p).encode()) > path_max - 2 * NAME_MARGIN:
        raise InputError(path, field, f"is {len(str(p).encode())} bytes long as an absolute "
                         f"path; at most {path_max - 2 * NAME_MARGIN} here")


def _exists(q: Path) -> bool:
    try:
        return q.exists()
    except OSError:         # e.g. a name too long to look up
        return False


def _parent_writable(p: Path, field: str) -> None:
    check_name_length(p, field)
    parent = p.parent if str(p.parent) else Path(".")
    try:
        parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise InputError(p, field, f"its directory cannot be created ({exc.strerror})") from None
    if not parent.is_dir():
        raise InputError(p, field, f"{parent} is not a directory")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise InputError(p, field, f"its directory {parent} is not writable")
    probe_writable(parent, p, field)


def probe_writable(directory, source=None, field: str = "-o/--output") -> None:
    """InputError unless a file can really be created in ``directory`` (``os.access``
    says yes to root on a read-only directory and knows nothing of read-only mounts)."""
    d = Path(directory)
    probe = d / f".forcespace-probe-{secrets.token_hex(4)}.tmp"
    try:
        os.close(os.open(probe, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600))
    except OSError as exc:
        raise InputError(source if source is not None else d, field,
                         f"its directory {d} is not writable ({exc.strerror})") from None
    with contextlib.suppress(OSError):
        os.unlink(probe)


def check_output_file(path, inputs=(), field: str = "-o/--output") -> Path:
    """Refuse an output path before any work: it must not be an input, nor an
    existing non-regular file (directory, symlink, device, fifo); its directory
    must exist or be creatable, and be writable. Returns the path."""
    p = Path(path)
    if p.name in ("", ".", "..") or str(path).endswith(os.sep):
        raise InputError(p, field, "must name a file, not a directory")
    check_name_length(p, field)
    for i in inputs:
        if i is None:
            continue
        q = Path(i)
        same = _exists(q) and p.exists() and os.path.samefile(p, q)
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


def check_figure_file(path, inputs=(), field: str = "-o/--output") -> list[Path]:
    """Refuse a figure path before any work: its format must be one matplotlib writes
    (by the suffix; none means PNG), and each file it produces (a PNG also writes a PDF
    twin) must pass :func:`check_output_file`. Returns those files."""
    from matplotlib.backend_bases import FigureCanvasBase

    from .figures import figure_targets

    p = Path(path)
    formats = FigureCanvasBase.get_supported_filetypes()
    suffix = p.suffix.lstrip(".").lower()
    if suffix and suffix not in formats:        # no suffix: written as PNG
        raise InputError(p, field, "must name a figure file: .png (also writes a .pdf), "
                         f"or one of {', '.join('.' + f for f in sorted(formats))}",
                         got=p.suffix or "(no suffix)")
    return [check_output_file(t, inputs=inputs, field=field) for t in figure_targets(p)]


def check_output_dir(path, field: str = "-o/--output") -> Path:
    """Refuse a run directory forcespace may not replace, before any work: an existing
    non-directory or symlink, the working directory or one that holds it, or a non-empty
    directory with an entry forcespace did not write (see :func:`foreign_entries`).
    Returns the path."""
    d = Path(path)
    check_name_length(d, field)
    if d.is_symlink() or (d.exists() and not d.is_dir()):
        raise InputError(d, field, "exists and is not a directory")
    here = Path.cwd().resolve()
    if d.resolve() == here or d.resolve() in here.parents:
        raise InputError(d, field, "is the working directory or holds it; forcespace never "
                         "replaces that: choose a new directory (nothing was changed)")
    if d.is_dir() and any(d.iterdir()):
        foreign = foreign_entries(d)
        if foreign:
            others = len(foreign) - 1
            what = ("a non-empty directory that forcespace did not create"
                    if own_entries(d) is None else
                    f"a directory forcespace made, but {foreign[0]!r}"
                    + (f" and {others} other entr{'y' if others == 1 else 'ies'} in it are"
                       if others else " in it is") + " not forcespace's")
            raise InputError(d, field, f"is {what}; forcespace replaces only directories "
                             "that hold nothing but its own files: choose a new or empty "
                             "directory (nothing was changed)")
    _parent_writable(d, field)
    return d


def _entries(d: Path) -> set[str]:
    """Every file and folder under ``d``, as paths relative to it (POSIX form)."""
    return {q.relative_to(d).as_posix() for q in d.rglob("*")}


def own_entries(path) -> set[str] | None:
    """The entries of the directory ``path`` forcespace recorded as written by it (None
    without a marker file)."""
    marker = Path(path) / RUN_DIR_MARKER
    if not marker.is_file():
        return None
    lines = marker.read_text(errors="replace").splitlines()
    return {ln for ln in lines[1:] if ln and not ln.startswith("#")}


def foreign_entries(path) -> list[str]:
    """Entries under the directory ``path`` that forcespace did not record as its own
    (sorted; the marker itself excluded)."""
    d = Path(path)
    own = (own_entries(d) or set()) | {RUN_DIR_MARKER}
    return sorted(e for e in _entries(d) if e not in own and not own & _temp_of(e))


def _temp_of(entry: str) -> set[str]:
    """The entries whose temporary file ``entry`` may be (``.NAME.tmp`` or
    ``.NAME.<8 hex>.tmp``, as forcespace's writers name them; a killed run leaves them)."""
    m = re.fullmatch(r"(.*/)?\.(.+?)(\.[0-9a-f]{8})?\.tmp", entry)
    if m is None:
        return set()
    folder = m.group(1) or ""
    return {folder + m.group(2), f"{folder}.{m.group(2)}"}


def mark_run_dir(path, entries=None) -> None:
    """Record ``entries`` (paths relative to the directory ``path``; default: everything
    in it now) as written by forcespace, beside those recorded before."""
    d = Path(path)
    new = _entries(d) if entries is None else {Path(e).as_posix() for e in entries}
    own = (own_entries(d) or set()) | new
    own.discard(RUN_DIR_MARKER)
    tmp = d / f".{RUN_DIR_MARKER}.{secrets.token_hex(4)}.tmp"
    try:
        tmp.write_text("# written by forcespace: the directory is replaced only while it "
                       "holds nothing but these entries\n"
                       + "".join(f"{e}\n" for e in sorted(own)))
        os.replace(tmp, d / RUN_DIR_MARKER)
    finally:
        tmp.unlink(missing_ok=True)


@contextlib.contextmanager
def recording_new_entries(path):
    """Record as forcespace's own what appears in the directory ``path`` during the
    block (a run's output files), also when the block fails."""
    d = Path(path)
    before = _entries(d)
    try:
        yield d
    except BaseException:
        with contextlib.suppress(OSError):    # e.g. a full disk: the block's error counts
            _record_new(d, before)
        raise
    _record_new(d, before)


def _record_new(d: Path, before: set) -> None:
    new = _entries(d) - before
    if new:
        mark_run_dir(d, new)


def new_temp_dir(d) -> Path:
    """An empty folder ``.NAME.<random>.tmp`` beside the directory ``d`` (where a writer
    fills what :func:`replace_run_dir` then puts in its place), with the permissions a
    plain ``mkdir`` gives (0777 less the umask; ``tempfile.mkdtemp`` would make it 0700)."""
    d = Path(d)
    for _ in range(100):
        tmp = d.parent / f".{d.name}.{secrets.token_hex(4)}.tmp"
        try:
            tmp.mkdir()
            return tmp
        except FileExistsError:
            continue
    raise FileExistsError(f"no free temporary name beside {d}")


@contextlib.contextmanager
def writing_run_dir(directory, field: str = "-o/--output"):
    """Yield an empty folder beside ``directory`` to write into; when the block ends it
    takes the directory's place (:func:`replace_run_dir`). On any error the folder is
    removed and ``directory`` left as it was; a write the filesystem refuses (disk full,
    read-only, ...) is one InputError naming ``directory``."""
    d = Path(directory)
    d.parent.mkdir(parents=True, exist_ok=True)
    tmp = new_temp_dir(d)
    try:
        yield tmp
        replace_run_dir(tmp, d, field)
    except BaseException as exc:
        shutil.rmtree(tmp, ignore_errors=True)
        refused = write_refused(d, exc)
        if refused is not None:
            raise refused from None
        raise


def replace_run_dir(tmp, directory, field: str = "-o/--output") -> Path:
    """Put the finished folder ``tmp`` (beside ``directory``, written by forcespace) in
    place of ``directory``: everything in ``tmp`` is recorded as forcespace's, and an
    existing ``directory`` is removed only if it still passes :func:`check_output_dir`
    (a file added since the check keeps it: InputError, ``tmp`` left to the caller)."""
    d, tmp = Path(directory), Path(tmp)
    mark_run_dir(tmp)
    if d.exists():
        check_output_dir(d, field)
        shutil.rmtree(d)
    os.replace(tmp, d)
    return d


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
def file_lock(lock_path, blocking: bool = True, timeout: float = -1, busy=None):
    """Hold an exclusive lock on the file ``lock_path`` (created if needed, removed when
    released). ``blocking=False``: raise ``busy`` (an exception) at once if another
    process holds it; ``timeout`` [s]: wait at most that long, then raise ``busy``.

    The lock file is unlinked while the lock is still held, as the last step: a process
    waiting on the old file sees it unlinked once it gets the lock (filelock checks
    ``st_nlink``) and starts over on the new file, so the removal never lets two
    processes hold the lock at once.
    """
    from filelock import FileLock, Timeout

    lock_path = Path(lock_path)
    lock = FileLock(lock_path, timeout=timeout, blocking=blocking, thread_local=False)
    try:
        lock.acquire()
    except Timeout:
        if busy is None:
            raise
        raise busy from None
    try:
        yield lock_path
    finally:
        if os.name != "nt":        # on Windows filelock removes it itself after release
            with contextlib.suppress(OSError):
                os.unlink(lock_path)
        lock.release()


def lock_path_of(path) -> Path:
    """The hidden lock file of ``path``: ``.NAME.lock`` beside it."""
    p = Path(path)
    return p.parent / f".{p.name}.lock"


@contextlib.contextmanager
def output_lock(path):
    """Hold an exclusive, non-blocking lock on ``path`` for writing; stale temp files
    of ``path`` are removed once it is held. InputError if another process holds it."""
    p = Path(path)
    _parent_writable(p, "-o/--output")
    busy = InputError(p, "(lock)", "is being written by another forcespace process; "
                      "wait for it or choose another output")
    with file_lock(lock_path_of(p), blocking=False, busy=busy):
        clean_stale_temps(p)
        yield p
