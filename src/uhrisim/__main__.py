"""``python -m uhrisim`` is the ``uhrisim`` command."""

import sys

from uhrisim.cli import main

sys.exit(main())
