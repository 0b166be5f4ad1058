"""``python -m fvf.cli``: the ``fvf`` command."""

import sys

from .main import main

sys.exit(main())
