"""numba kernels of forcespace: one decorator, with an on-disk cache keyed by the sources.

Every kernel is declared with :func:`kernel` (``numba.njit`` with ``cache=True``).
numba's on-disk cache checks only the source file of the function it loads: a
kernel that calls or inlines a function of another module (the time step calls
the Gauss-Seidel solver) would keep running the old callee after that module is
edited. So forcespace's kernels are stamped with a hash of *every* module that
defines kernels (:func:`kernel_source_hash`) instead of their own file's time
stamp: any kernel edit recompiles them all, and a run always executes the code
it reports as its version.

The stamp is applied by cache locators (numba's own, unchanged in where they put
the cache: ``NUMBA_CACHE_DIR`` if set, else ``__pycache__`` beside the source,
else the user-wide cache) that claim only functions defined in forcespace's own
files; they are registered with numba the first time a kernel is declared.
Nothing else of numba's or the environment's configuration is touched.
"""
from __future__ import annotations

import functools
import hashlib
from pathlib import Path

from numba import njit

PACKAGE_DIR = Path(__file__).resolve().parent    # the forcespace package, where installed


def sources_hash(root=None, only=None) -> str:
    """SHA-1 (12 hex digits) of the .py files under ``root`` (default: the installed
    package), each with its path relative to root; ``only(text)`` selects files."""
    root = Path(root or PACKAGE_DIR)
    h = hashlib.sha1()
    for path in sorted(root.rglob("*.py")):
        text = path.read_bytes()
        if only is None or only(text):
            h.update(path.relative_to(root).as_posix().encode() + b"\0" + text)
    return h.hexdigest()[:12]


@functools.lru_cache(maxsize=1)
def kernel_source_hash(package_dir=None) -> str:
    """SHA-1 (12 hex digits) of the modules under ``package_dir`` (default: this
    package) that declare kernels."""
    return sources_hash(package_dir, only=lambda text: b"@kernel" in text or b"@njit" in text)


def _ours(py_file) -> bool:
    try:
        return Path(py_file).resolve().is_relative_to(PACKAGE_DIR)
    except (OSError, ValueError):
        return False


@functools.lru_cache(maxsize=1)
def _register_locators() -> bool:
    """Put stamped copies of numba's file-backed locators first in its list (once)."""
    try:
        from numba.core import caching
        impl = caching.CacheImpl
        bases = (caching.UserProvidedCacheLocator, caching.InTreeCacheLocator,
                 caching.UserWideCacheLocator)
    except (ImportError, AttributeError):   # another numba layout: plain numba caching
        return False

    def stamped(base):
        class Stamped(base):
            def get_source_stamp(self):
                return kernel_source_hash()

            @classmethod
            def from_function(cls, py_func, py_file):
                return super().from_function(py_func, py_file) if _ours(py_file) else None

        Stamped.__name__ = f"Forcespace{base.__name__}"
        return Stamped

    impl._locator_classes[:0] = [stamped(b) for b in bases]
    return True


def kernel(*args, **options):
    """``numba.njit(cache=True, **options)`` for forcespace's kernels (use as
    ``@kernel`` or ``@kernel(inline="always")``), cached under the source stamp."""
    _register_locators()
    options.setdefault("cache", True)
    return njit(*args, **options)


def uncached_kernels(packages=("forcespace",)) -> list[str]:
    """Names of the kernels of the modules under ``packages`` (imported here) that numba's
    on-disk cache does not hold for this source stamp: they compile at their first call
    (about a minute for the engine's on a fresh install). Empty when numba's cache layout
    is not the one known here (nothing can be said)."""
    import importlib

    from numba.core.registry import CPUDispatcher

    names = []
    for path in sorted(PACKAGE_DIR.rglob("*.py")):
        module = "forcespace." + ".".join(path.relative_to(PACKAGE_DIR).with_suffix("").parts)
        if not module.startswith(tuple(packages)) or b"@kernel" not in path.read_bytes():
            continue
        for obj in list(vars(importlib.import_module(module)).values()):
            if isinstance(obj, CPUDispatcher) and obj.__module__ == module:
                try:
                    cached = bool(obj._cache._cache_file._load_index())
                except Exception:           # another numba: say nothing
                    cached = True
                if not cached:
                    names.append(f"{module}.{obj.__name__}")
    return sorted(set(names))


def compile_notice(packages=("forcespace",), stream=None) -> bool:
    """Print one line on ``stream`` (default: stderr, when it is a terminal: a log or a
    pipe gets the command's own lines only) when kernels under ``packages`` will compile
    (the first run of this version on this machine), so a first command is not silent
    for a minute; True if printed."""
    import sys

    if stream is None and not sys.stderr.isatty():
        return False
    todo = uncached_kernels(packages)
    if todo:
        print(f"forcespace: compiling {len(todo)} numba kernels of this version (once per "
              "machine, 20-60 s; cached afterwards)...", file=stream or sys.stderr,
              flush=True)
    return bool(todo)
