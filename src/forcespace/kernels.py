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
