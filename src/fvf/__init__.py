"""fvf: operator-based tangent vector fields on triangle meshes.

A tangent field v is represented by the operator it induces on functions,
D_v f = ⟨v, ∇f⟩. The flat namespace ``fvf.name`` holds what users call: the ``__all__`` of
every layer below, less the few names each keeps to itself (its ``NOT_FLAT``). The
subpackages are the layers (``docs/architecture.md``); each imports only those above it
in this list::

    errors      every error and warning class (also reachable as ``fvf.Name``)
    numerics/   exponential action, eigensolvers, orderings, factorizations (no meshes)
    mesh/       TriMesh, checks of user arrays, repair, diagnostics, shapes, Spot
    io/         mesh files (OBJ, OFF, PLY) and data files (.npz) of functions and fields
    calculus    areas, grad, div, J, I_V^F, I_F^V, Laplacian (chapter §3.1)
    operators/  D^F_v, D^V_v and duals (§3.3), D̃_v (§4.2), brackets and ad_v (§3.6, §4.3)
    flows/      functional flows (§3.5) and flows with guarantees, field transport (§4.5),
                fluids
    spectral/   Laplace–Beltrami bases, reduced operators and the spectral flow methods,
                descriptors, functional maps, correspondence
    design/     connection Laplacians, smoothest, constrained, Killing, map-consistent and
                commuting fields, N-direction fields, singularities
    param/      seamless parameterizations and quad meshes
    chapter     one alias per symbol of the chapter
    examples    the chapter's scenes: Spot, the fields of Fig. 12, the compressible case
    batch/      tasks over many meshes on Dask (``import fvf.batch``; extra ``[batch]``)
    viz/        the pictures (``import fvf.viz``; extra ``[viz]``)
    cli/        the ``fvf`` command

This module hands names on: it imports the layers up to ``examples`` and never ``batch``,
``viz`` or ``cli``, which import it.
"""

from __future__ import annotations

import warnings as _warnings

from . import (
    calculus,
    chapter,
    design,
    errors,
    examples,
    flows,
    io,
    mesh,
    numerics,
    operators,
    param,
    spectral,
)
from ._version import __version__ as __version__
from .calculus import *  # noqa: F403
from .design import *  # noqa: F403
from .errors import *  # noqa: F403
from .flows import *  # noqa: F403
from .io import *  # noqa: F403
from .mesh import *  # noqa: F403
from .numerics import *  # noqa: F403
from .operators import *  # noqa: F403
from .param import *  # noqa: F403
from .spectral import *  # noqa: F403

#: The layers whose ``__all__`` the flat namespace re-exports, in layer order.
_FLAT = (errors, numerics, mesh, io, calculus, operators, flows, spectral, design, param)

for _name in (name for layer in _FLAT for name in layer.NOT_FLAT):
    del globals()[_name]  # imported by the ``*`` above; kept to its subpackage
del _name

#: Plumbing that lived in the flat namespace before the layout was split into
#: subpackages: still reachable as ``fvf.name`` (with a DeprecationWarning) and, for
#: good, from the submodule named here.
_MOVED = {
    "diag": "fvf.calculus",
    "field_product": "fvf.calculus",
    "field_inner": "fvf.calculus",
    "hat_gradients": "fvf.calculus",
    "GROWTH_LIMIT": "fvf.flows.functional",
    "DEFAULT_REPAIR_STEPS": "fvf.mesh.repair",
}


def __getattr__(name: str) -> object:
    home = _MOVED.get(name)
    if home is None:
        raise AttributeError(f"module 'fvf' has no attribute {name!r}")
    from importlib import import_module

    _warnings.warn(
        f"fvf.{name} is plumbing and moved out of the flat namespace; use {home}.{name}",
        DeprecationWarning,
        stacklevel=2,
    )
    return getattr(import_module(home), name)


__all__ = [name for layer in _FLAT for name in layer.__all__ if name not in layer.NOT_FLAT]
__all__ += ["chapter", "examples", "mesh", "io", "operators", "flows", "spectral"]
__all__ += ["design", "numerics", "param"]
