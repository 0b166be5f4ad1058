"""Functional vector field operators: D^F_v, D^V_v and their duals (§3.3,
:mod:`.directional`), the divergence-based D̃_v and duals (§4.2, :mod:`.divergence`), and the
vertex and mixed Lie brackets, B(v, w) and ad_v (§3.6, §4.3–4.4, :mod:`.brackets`).
"""

from .brackets import (
    B,
    ad,
    bracket_F,
    bracket_norm,
    bracket_smoothness,
    bracket_V,
    commutator_field,
    dirichlet_ratio,
)
from .directional import D_F, D_V, Dbar_F, Dbar_V, directional_derivatives, extract_field
from .divergence import Dtilde_dual_F, Dtilde_dual_V, Dtilde_F, Dtilde_V

__all__ = [
    "directional_derivatives",
    "D_F",
    "D_V",
    "Dbar_F",
    "Dbar_V",
    "extract_field",
    "Dtilde_F",
    "Dtilde_V",
    "Dtilde_dual_F",
    "Dtilde_dual_V",
    "bracket_V",
    "bracket_F",
    "B",
    "ad",
    "commutator_field",
    "bracket_norm",
    "bracket_smoothness",
    "dirichlet_ratio",
]

#: Every name of ``__all__`` is also ``fvf.name`` (the flat namespace leaves none out).
NOT_FLAT: frozenset[str] = frozenset()
