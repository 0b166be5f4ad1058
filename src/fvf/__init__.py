"""fvf: operator-based tangent vector fields on triangle meshes.

A tangent field v is represented by the operator it induces on functions,
D_v f = ⟨v, ∇f⟩. The flat namespace holds the mesh, the calculus, the operators and the
flows; :mod:`fvf.chapter` holds one alias per symbol of the source chapter.
"""

from . import chapter, examples
from .bracket import (
    B,
    ad,
    bracket_F,
    bracket_norm,
    bracket_smoothness,
    bracket_V,
    commutator_field,
    dirichlet_ratio,
)
from .calculus import (
    diag,
    div,
    divergence,
    face_areas,
    face_mass,
    face_to_vertex,
    face_to_vertex_values,
    field_inner,
    field_product,
    grad,
    gradient,
    hat_gradients,
    laplacian,
    poisson_bracket,
    rotate,
    rotation,
    stiffness,
    vertex_areas,
    vertex_mass,
    vertex_to_face,
    vertex_to_face_values,
)
from .commuting import acap_energy_matrix, acap_fields, rescale, rescaling_operator
from .connection import (
    connection_energy,
    connection_laplacian,
    connection_mass,
    real_connection_laplacian,
    restrict_to_tangent,
    smoothest_fields,
    tangent_basis_matrix,
)
from .design import closest_faces, design_field, locate_points
from .divergence import Dtilde_dual_F, Dtilde_dual_V, Dtilde_F, Dtilde_V
from .eigen import SpectralFallbackWarning, eigen_residuals, smallest_eigenpairs
from .errors import *  # noqa: F403
from .errors import __all__ as _errors_all
from .fields import as_face_field, as_face_function, as_vertex_function
from .flow import GROWTH_LIMIT, FunctionalFlow
from .flows import TransportFlow, dual_edge_fluxes, flow, skew_operator, upwind_operator
from .fluid import FluidResult, fluid_time_step, ideal_fluid
from .fmaps import functional_map, functional_map_from_bases, map_quality
from .io import read_mesh, write_mesh
from .killing import commutator_energy, killing_fields
from .mesh import TriMesh
from .operators import D_F, D_V, Dbar_F, Dbar_V, directional_derivatives, extract_field
from .repair import (
    DEFAULT_REPAIR_STEPS,
    RepairResult,
    orient_faces,
    remove_degenerate_faces,
    remove_duplicate_faces,
    remove_duplicate_vertices,
    remove_unreferenced_vertices,
    repair_mesh,
    split_nonmanifold_edges,
    split_nonmanifold_vertices,
)
from .shapes import disk, icosphere, jittered_sphere, torus
from .singularities import (
    ZeroFieldWarning,
    face_indices,
    face_singularities,
    singularities,
    singularity_positions,
    vertex_indices,
)
from .spectral import SpectralBasis, gradient_field_basis, laplace_basis
from .transport import Ad, FieldTransport, TransportResult, interpolate

__version__ = "0.1.0"

__all__ = [
    "TriMesh",
    "read_mesh",
    "write_mesh",
    "remove_unreferenced_vertices",
    "remove_duplicate_vertices",
    "remove_degenerate_faces",
    "remove_duplicate_faces",
    "orient_faces",
    "split_nonmanifold_vertices",
    "split_nonmanifold_edges",
    "repair_mesh",
    "RepairResult",
    "DEFAULT_REPAIR_STEPS",
    "icosphere",
    "jittered_sphere",
    "torus",
    "disk",
    "chapter",
    "examples",
    "face_areas",
    "vertex_areas",
    "hat_gradients",
    "vertex_mass",
    "face_mass",
    "rotation",
    "rotate",
    "diag",
    "field_product",
    "field_inner",
    "face_to_vertex",
    "vertex_to_face",
    "grad",
    "div",
    "stiffness",
    "laplacian",
    "gradient",
    "divergence",
    "poisson_bracket",
    "vertex_to_face_values",
    "face_to_vertex_values",
    "D_F",
    "D_V",
    "Dbar_F",
    "Dbar_V",
    "directional_derivatives",
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
    "FunctionalFlow",
    "flow",
    "GROWTH_LIMIT",
    "as_face_field",
    "as_face_function",
    "as_vertex_function",
    "vertex_indices",
    "singularities",
    "face_indices",
    "face_singularities",
    "singularity_positions",
    "ZeroFieldWarning",
    "connection_laplacian",
    "connection_mass",
    "connection_energy",
    "real_connection_laplacian",
    "restrict_to_tangent",
    "smoothest_fields",
    "tangent_basis_matrix",
    "design_field",
    "locate_points",
    "closest_faces",
    "smallest_eigenpairs",
    "eigen_residuals",
    "SpectralFallbackWarning",
    "SpectralBasis",
    "laplace_basis",
    "gradient_field_basis",
    "killing_fields",
    "commutator_energy",
    "functional_map",
    "functional_map_from_bases",
    "map_quality",
    "Ad",
    "FieldTransport",
    "TransportResult",
    "interpolate",
    "rescale",
    "rescaling_operator",
    "acap_fields",
    "acap_energy_matrix",
    "bracket_norm",
    "bracket_smoothness",
    "dirichlet_ratio",
    "TransportFlow",
    "upwind_operator",
    "skew_operator",
    "dual_edge_fluxes",
    "ideal_fluid",
    "fluid_time_step",
    "FluidResult",
    *_errors_all,
]
