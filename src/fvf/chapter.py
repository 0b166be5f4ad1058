"""One name per chapter symbol, for readers of the paper.

Every name here is a thin alias of the function that implements it (mesh first; fields
as (m, 3) arrays; PL functions (n,); PC functions (m,)). Equation numbers refer to the
chapter, restated in ``docs/chapter.md`` (e.g. docs/chapter.md, eq. (36) for D_V);
``docs/operators.md`` has the full table.

=================  ==============================  =================================
symbol             fvf function                    shape
=================  ==============================  =================================
A_F, A_V           face_areas, vertex_areas        (m,), (n,)
grad (27–28)       calculus.grad                   (3m, n)
div (29)           calculus.div                    (n, 3m)
J                  calculus.rotation               (3m, 3m)
I_VF = I_V^F       calculus.face_to_vertex         (n, m)
I_FV = I_F^V       calculus.vertex_to_face         (m, n)
L                  calculus.laplacian              (n, n)
D_F, D_V (35–36)   operators.D_F, D_V              (m, n), (n, n)
Dbar_F, Dbar_V     operators.Dbar_F, Dbar_V        (m, 3m), (n, 3m)
Dtilde_F, _V (52)  operators.Dtilde_F, _V          (n, m), (n, n)
Dtilde_dual_F/_V   operators.Dtilde_dual_F, _V     (n, 3m)
bracket_V (46)     operators.bracket_V             (n, n), 2-ring
bracket_F (54)     operators.bracket_F             (n, n), 1-ring
B (55)             operators.B                     (3m, 3m)
ad (62–63)         operators.ad                    (3n, 3m), fvf layout
poisson_bracket    calculus.poisson_bracket        (m,)
flow (42)          flows.flow (method="chapter";   (n,) or (T, n)
                   upwind, skew, cayley, spectral)
extract_field (40) operators.extract_field         (rows of D, 3)
laplace_basis      spectral.laplace_basis          (k,), (n, k)
killing_fields     design.killing_fields           (count,), (count, m, 3)
singularities      design.singularities            (s,), (s,)
functional_map     spectral.functional_map         (k, k)
Ad (67)            flows.Ad                        (m, 3) or (T, m, 3)
interpolate (68)   flows.interpolate               (m, 3) or (T, m, 3)
rescale (65–66)    design.rescale                  (n,)
acap_fields        design.acap_fields              (k, m, 3)
=================  ==============================  =================================
"""

from __future__ import annotations

from .calculus import (
    div,
    face_areas,
    face_to_vertex,
    grad,
    laplacian,
    poisson_bracket,
    vertex_areas,
    vertex_to_face,
)
from .calculus import rotation as J
from .design.commuting import acap_fields, rescale
from .design.indices import singularities
from .design.killing import killing_fields
from .flows.dispatch import flow
from .flows.field_transport import Ad, interpolate
from .operators.brackets import B, ad, bracket_F, bracket_V
from .operators.directional import D_F, D_V, Dbar_F, Dbar_V, extract_field
from .operators.divergence import Dtilde_dual_F, Dtilde_dual_V, Dtilde_F, Dtilde_V
from .spectral.basis import laplace_basis
from .spectral.fmaps import functional_map

A_F = face_areas
A_V = vertex_areas
I_VF = face_to_vertex
I_FV = vertex_to_face
L = laplacian

__all__ = [
    "A_F",
    "A_V",
    "grad",
    "div",
    "J",
    "I_VF",
    "I_FV",
    "L",
    "D_F",
    "D_V",
    "Dbar_F",
    "Dbar_V",
    "Dtilde_F",
    "Dtilde_V",
    "Dtilde_dual_F",
    "Dtilde_dual_V",
    "bracket_V",
    "bracket_F",
    "B",
    "ad",
    "poisson_bracket",
    "flow",
    "extract_field",
    "laplace_basis",
    "killing_fields",
    "singularities",
    "functional_map",
    "Ad",
    "interpolate",
    "rescale",
    "acap_fields",
]
