"""``python -m loomfmu``: the same as the ``loomfmu`` command."""
import sys

from .cli import main

sys.exit(main())
