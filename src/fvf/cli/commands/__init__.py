"""The subcommands of ``fvf``, one module each, registered on import
(:func:`fvf.cli.registry.register_command`).

:data:`MODULES` fixes the order of ``fvf --help``: the mesh itself (demo, info, repair),
the chapter's operators on given fields (flow, bracket, transport), fields designed from
the mesh and the quad mesh along them (design, quad), maps between shapes (match,
symmetry), pictures (render, view), and many meshes at once (batch). A new command is a
new module here, added to :data:`MODULES`.
"""

from __future__ import annotations

import importlib

#: The command modules, in the order ``fvf --help`` lists their commands.
MODULES = (
    "demo",
    "info",
    "repair",
    "flow",
    "bracket",
    "transport",
    "design",
    "quad",
    "match",
    "symmetry",
    "render",
    "view",
    "batch",
)

for _name in MODULES:  # each import registers its command
    importlib.import_module(f"{__name__}.{_name}")
