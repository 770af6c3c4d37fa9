"""Self-describing, atomically written HDF5 files.

Every dataset carries ``units`` and ``description`` attributes; 2-D tables also
carry ``columns``. Files are written to a temporary name in the target folder
and renamed into place, so a crash never leaves a half-written result.
"""
from __future__ import annotations

import contextlib
import errno
import functools
import io
import os
import re
import secrets
from pathlib import Path

import h5py
import numpy as np

from .. import __version__
from ..errors import InputError
from ..kernels import sources_hash

# what the filesystem answers to a write it refuses: disk full, file too large, quota,
# read-only, permission, I/O error
WRITE_ERRNOS = {errno.ENOSPC, errno.EFBIG, errno.EDQUOT, errno.EROFS, errno.EACCES, errno.EIO}


def write_refused(path, exc: BaseException) -> InputError | None:
    """The one-line InputError for ``exc`` if it is a write the filesystem refused
    (WRITE_ERRNOS) while writing ``path`` (whose old content was left as it was), else None."""
    if isinstance(exc, OSError) and exc.errno in WRITE_ERRNOS:
        return InputError(path, "(write)", f"could not be written: "
                          f"{os.strerror(exc.errno)}; nothing was changed")
    return None


def _new_temp(path: Path) -> str:
    """Create an empty temporary file ``.NAME.<random>.tmp`` beside ``path`` with the
    permissions a plain ``open`` would give (0666 less the umask)."""
    for _ in range(100):
        tmp = path.parent / f".{path.name}.{secrets.token_hex(4)}.tmp"
        try:
            os.close(os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666))
            return str(tmp)
        except FileExistsError:
            continue
    raise FileExistsError(f"no free temporary name beside {path}")


@contextlib.contextmanager
def atomic_path(path):
    """Yield a temporary path beside ``path``; rename it over ``path`` on success.

    On any exception the temporary file is removed and ``path`` is untouched.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = _new_temp(path)
    try:
        yield tmp
        os.replace(tmp, path)
    except BaseException as exc:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp)
        refused = write_refused(path, exc)
        if refused is not None:
            raise refused from None
        raise


# Version of the file layouts (packing, ensemble, soft network). Bump it when a reader
# of this version could misread a file written by the next one; files without the
# attribute are version 1 (before it existed) and are read as such.
# 3: packing files may hold spheres (root attribute dimension = 3; 2-D files unchanged).
FORMAT_VERSION = 3


@functools.lru_cache(maxsize=1)
def source_hash() -> str:
    """SHA-1 (12 hex digits) of the installed forcespace sources (every .py file of the
    package): two different codes are never stamped alike, installed or not."""
    return sources_hash()


def code_version() -> str:
    """The package version plus a hash of its sources, ``0.1.0+src.1a2b3c4d5e6f``: the
    exact code that wrote a file, without asking git (which an installed copy has not)."""
    return f"{__version__}+src.{source_hash()}"


class MemoryFile:
    """An HDF5 file held in memory: pass it wherever forcespace takes an output or
    input file path (e.g. a sampler's ``out``) to keep the result off the disk."""

    def __init__(self, name: str = "<memory>"):
        self.name = name
        self.data: bytes | None = None

    def exists(self) -> bool:
        return self.data is not None

    def __str__(self) -> str:
        return self.name

    def __repr__(self) -> str:
        size = "empty" if self.data is None else f"{len(self.data)} bytes"
        return f"MemoryFile({self.name!r}, {size})"


def exists(path) -> bool:
    """Whether a file path or a :class:`MemoryFile` holds a file."""
    return path.exists() if isinstance(path, MemoryFile) else Path(path).exists()


@contextlib.contextmanager
def atomic_h5(path, mode_attrs: dict | None = None):
    """Open a new HDF5 file for writing; it reaches ``path`` atomically on success.

    Yields an open ``h5py.File``. Root attributes ``forcespace_version``,
    ``code_version`` (with a hash of the sources), ``format_version`` and ``file_kind``
    (from ``mode_attrs``) are set. The file is built in memory
    and written with plain file I/O through :func:`atomic_path`: a failed
    write (full disk, quota) is one clean error, where HDF5 writing to the
    disk itself left an unclosable file id that crashed the interpreter.
    """
    buf = io.BytesIO()
    with h5py.File(buf, "w") as f:
        f.attrs["forcespace_version"] = __version__
        f.attrs["code_version"] = code_version()
        f.attrs["format_version"] = FORMAT_VERSION
        for k, v in (mode_attrs or {}).items():
            f.attrs[k] = v
        yield f
    _write_bytes(path, buf)


@contextlib.contextmanager
def atomic_replace_copy(path):
    """Modify an existing HDF5 file atomically: edit an in-memory copy, then write
    it to a temporary file renamed over ``path``. Used by the resumable samplers."""
    buf = io.BytesIO(path.data if isinstance(path, MemoryFile) else Path(path).read_bytes())
    with h5py.File(buf, "r+") as f:
        yield f
    _write_bytes(path, buf)


def _write_bytes(path, buf: io.BytesIO) -> None:
    if isinstance(path, MemoryFile):
        path.data = buf.getvalue()
        return
    with atomic_path(path) as tmp, open(tmp, "wb") as fh:
        fh.write(buf.getbuffer())
        fh.flush()
        os.fsync(fh.fileno())


def write_dataset(group, name, data, units: str, description: str, columns=None):
    """Write one dataset with its ``units``, ``description`` and optional ``columns``."""
    ds = group.create_dataset(name, data=np.asarray(data))
    ds.attrs["units"] = units
    ds.attrs["description"] = description
    if columns is not None:
        ds.attrs["columns"] = list(columns)
    return ds


def missing_name(exc: KeyError) -> str:
    """The dataset, group or attribute name of h5py's KeyError ("Unable to open object
    (object 'x' doesn't exist)" -> "x"), or the plain key of a dict's."""
    text = str(exc.args[0]) if exc.args else "?"
    found = re.search(r"(?:object|attribute:) '([^']*)'", text)
    return found.group(1) if found else text


def open_h5(path, kind: str | None = None):
    """Open an existing forcespace HDF5 file read-only, with a clear error.

    ``kind`` checks the root attribute ``file_kind`` (e.g. "packing").
    """
    if isinstance(path, MemoryFile):
        if path.data is None:
            raise InputError(path, "(file)", "is empty")
        p, source = path, io.BytesIO(path.data)
    else:
        p = source = Path(path)
        try:
            found = p.exists()
        except OSError as exc:            # e.g. a name longer than the filesystem takes
            raise InputError(p, "(file)", f"cannot be looked up ({exc.strerror})") from None
        if not found:
            raise InputError(p, "(file)", "does not exist")
    try:
        f = h5py.File(source, "r")
    except OSError as exc:
        raise InputError(p, "(file)", f"is not a readable HDF5 file ({exc})") from None
    raw = f.attrs.get("format_version", 1)
    try:
        version = int(raw)
        if version != raw or version < 1:
            raise ValueError
    except (TypeError, ValueError):
        f.close()
        raise InputError(p, "format_version", f"must be an integer 1..{FORMAT_VERSION} (the "
                         "file layout's version); the file was changed or not written by "
                         "forcespace", got=raw.decode() if isinstance(raw, bytes) else
                         (raw.item() if hasattr(raw, "item") else raw)) from None
    if version > FORMAT_VERSION:
        f.close()
        raise InputError(p, "format_version", f"was written by a newer forcespace (file format "
                         f"{version}); this one reads formats up to {FORMAT_VERSION}: upgrade "
                         "forcespace", got=version)
    if kind is not None:
        got = f.attrs.get("file_kind")
        if got != kind:
            f.close()
            raise InputError(p, "file_kind", f"expected a forcespace '{kind}' file", got=got)
    return f
