"""Progress bars for long work (tqdm on stderr; silent when disabled)."""
from __future__ import annotations

import sys

from tqdm.auto import tqdm


def progress(total=None, desc="", unit="it", disable=False):
    """A tqdm bar on stderr; ``disable=True`` gives a no-op bar with the same API."""
    return tqdm(total=total, desc=desc, unit=unit, disable=disable, file=sys.stderr,
                dynamic_ncols=True, mininterval=0.5)
