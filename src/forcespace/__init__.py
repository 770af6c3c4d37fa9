"""forcespace: force indeterminacy in jammed packings of rigid disks.

Layers, in the order the data flows:
scene -> dynamics (contacts, nlgs, stepping) -> jamming -> packing
-> statics (slice, equilibrium matrix) -> ensemble (exact analysis, samplers)
-> measures -> studies.
"""
from importlib.metadata import PackageNotFoundError, version as _version

try:
    __version__ = _version("forcespace")
except PackageNotFoundError:  # running from a source tree without install
    __version__ = "0.0.0+unknown"

from .errors import ForcespaceError, InputError, NumericalError  # noqa: E402

__all__ = ["__version__", "ForcespaceError", "InputError", "NumericalError"]
