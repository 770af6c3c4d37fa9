"""``python -m forcespace.cli``: the ``forcespace`` command."""
import sys

from . import main

sys.exit(main())
