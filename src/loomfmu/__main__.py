"""``python -m loomfmu``: the same as the ``loomfmu`` command."""
import sys

from loomfmu.cli.dispatch import main

sys.exit(main())
