"""``python -m fvf``: the ``fvf`` command (as ``python -m fvf.cli``)."""

import sys

from .cli.main import main

sys.exit(main())
