"""The ``fvf`` command (:mod:`.main`) and its demo (:mod:`.demo`). Holds no math: every
computation is a call into the library."""

from .main import main

__all__ = ["main"]
