"""Seamless parameterization and quad meshing from cross fields.

frame_field  the frame fitted: the default cross field (fvf.design_field) and its scaling
cutmesh      the combed field on the cut mesh (fvf.cut_graph, fvf.comb) and its wedges
seams        transition functions across the cut, as a linear map of free variables
rounding     the lattice of integer unknowns and greedy mixed-integer rounding
seamless     the Poisson fit and :func:`seamless_parameterization`
uv_folds     local stiffening of flipped uv triangles after rounding
extraction   the integer grid of a parameterization as a quad mesh
quadmesh     :func:`quad_mesh` (parameterize, then extract)
quality      :func:`quad_quality`
quad_folds   quads folded in 3D: :func:`folded_quads`, untangling on the surface

Instant Meshes, the reference remesher of the comparisons, is in :mod:`fvf.peers`.
"""

from .extraction import QuadMesh, edge_transitions, extract_quads
from .frame_field import default_cross_field
from .quad_folds import folded_quads
from .quadmesh import quad_mesh
from .quality import QuadQuality, quad_quality
from .seamless import SeamlessParameterization, seamless_parameterization
from .symmetry import quad_symmetry_error, symmetrize_cross_field

__all__ = [
    "QuadMesh",
    "QuadQuality",
    "SeamlessParameterization",
    "default_cross_field",
    "edge_transitions",
    "extract_quads",
    "folded_quads",
    "quad_mesh",
    "quad_quality",
    "seamless_parameterization",
    "quad_symmetry_error",
    "symmetrize_cross_field",
]

#: Names of ``__all__`` that the flat namespace ``fvf`` leaves out (reach them as
#: ``fvf.param.name``); every other name here is also ``fvf.name``.
NOT_FLAT: frozenset[str] = frozenset(
    {
        "QuadMesh",
        "default_cross_field",
        "edge_transitions",
        "extract_quads",
    }
)
