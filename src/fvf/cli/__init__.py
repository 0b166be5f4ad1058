"""The ``fvf`` command (:mod:`.main`; one module per subcommand in :mod:`.commands`, each
registered with :func:`.registry.register_command`) and its demo (:mod:`.demo`). Holds no
math: every computation is a call into the library."""

from .main import main

__all__ = ["main"]
