"""One numba cache directory per version of the kernel sources.

numba's on-disk cache (``cache=True``) checks only the source file of the function it
loads: a kernel that calls or inlines a function of another module (``dynamics`` calls
``nlgs_solve``) keeps running the old callee after that module is edited. Keying the
cache directory by a hash of every module that defines kernels makes any kernel edit
start a fresh cache, so a run always executes the code it reports as its version.

The directory is ``$NUMBA_CACHE_DIR/<hash>`` (default base: ``~/.cache/forcespace/numba``);
it must be set before numba reads its configuration, i.e. before the first kernel
module is imported, which :mod:`forcespace` does on import.
"""
from __future__ import annotations

import hashlib
import os
import sys
from pathlib import Path

_ENV = "NUMBA_CACHE_DIR"


def kernel_source_hash(package_dir=None) -> str:
    """SHA-1 (12 hex digits) of the modules of ``package_dir`` (default: this package)
    that define numba kernels."""
    h = hashlib.sha1()
    for path in sorted(Path(package_dir or Path(__file__).parent).glob("*.py")):
        text = path.read_bytes()
        if b"@njit" in text:
            h.update(path.name.encode() + b"\0" + text)
    return h.hexdigest()[:12]


def use_versioned_cache() -> str:
    """Point numba's cache at ``<base>/<kernel hash>`` (idempotent: worker processes
    inherit the already versioned directory). Returns the directory."""
    tag = kernel_source_hash()
    current = os.environ.get(_ENV, "")
    if current and Path(current).name == tag:
        return current
    base = Path(current) if current else Path.home() / ".cache" / "forcespace" / "numba"
    cache = str(base / tag)
    os.environ[_ENV] = cache
    config = sys.modules.get("numba.core.config")
    if config is not None:          # numba imported before forcespace: set it directly
        config.CACHE_DIR = cache
    return cache
