"""fvf: operator-based tangent vector fields on triangle meshes.

A tangent field v is represented by the operator it induces on functions,
D_v f = ⟨v, ∇f⟩. The flat namespace ``fvf.name`` holds what users call; the subpackages
show the layers (``docs/architecture.md``)::

    mesh/       TriMesh, checks of user arrays, repair, diagnostics, shapes, built-in meshes
    io/         mesh files (OBJ, OFF, PLY) and data files (.npz) of functions and fields
    calculus    areas, grad, div, J, I_V^F, I_F^V, Laplacian (chapter §3.1)
    operators/  D^F_v, D^V_v and duals (§3.3), D̃_v (§4.2), brackets and ad_v (§3.6, §4.3)
    flows/      functional flows (§3.5) and flows with guarantees, field transport (§4.5),
                fluids
    spectral/   Laplace–Beltrami bases, reduced operators, functional maps
    design/     connection Laplacians, smoothest, constrained, Killing, map-consistent and
                commuting fields, singularities
    numerics/   exponential action, eigensolvers, orderings (no mesh imports)
    chapter     one alias per symbol of the chapter
    errors      every error and warning class (also reachable as ``fvf.Name``)
    cli/, viz/  the ``fvf`` command and the pictures (never imported by the layers above)
"""

from __future__ import annotations

import warnings as _warnings
from importlib import metadata as _metadata

from . import chapter, design, flows, io, mesh, numerics, operators, param, spectral
from .calculus import (
    div,
    divergence,
    face_areas,
    face_mass,
    face_to_vertex,
    face_to_vertex_values,
    grad,
    gradient,
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
from .design import (
    acap_energy_matrix,
    acap_fields,
    cancel_close_singularities,
    closest_faces,
    comb,
    commutator_energy,
    connection_energy,
    connection_laplacian,
    connection_mass,
    cut_graph,
    design_field,
    face_indices,
    face_singularities,
    frame_report,
    from_power,
    killing_fields,
    locate_points,
    period_jumps,
    real_connection_laplacian,
    rescale,
    rescale_frame,
    rescaling_operator,
    restrict_to_tangent,
    separate_close_singularities,
    singularities,
    singularity_positions,
    smoothest_fields,
    tangent_basis_matrix,
    to_power,
    vertex_indices,
)
from .errors import *  # noqa: F403
from .errors import __all__ as _errors_all
from .flows import (
    Ad,
    FieldTransport,
    FluidResult,
    FunctionalFlow,
    TransportFlow,
    TransportResult,
    dual_edge_fluxes,
    flow,
    fluid_time_step,
    ideal_fluid,
    interpolate,
    skew_operator,
    upwind_operator,
)
from .io import read_mesh, write_mesh
from .mesh import (
    RepairResult,
    TriMesh,
    as_face_field,
    as_face_function,
    as_mesh,
    as_vertex_function,
    disk,
    icosphere,
    jittered_sphere,
    orient_faces,
    principal_curvatures,
    remove_degenerate_faces,
    remove_duplicate_faces,
    remove_duplicate_vertices,
    remove_unreferenced_vertices,
    repair_mesh,
    split_nonmanifold_edges,
    split_nonmanifold_vertices,
    spot,
    torus,
)
from .mesh import builtin as examples
from .numerics import eigen_residuals, smallest_eigenpairs
from .operators import (
    D_F,
    D_V,
    B,
    Dbar_F,
    Dbar_V,
    Dtilde_dual_F,
    Dtilde_dual_V,
    Dtilde_F,
    Dtilde_V,
    ad,
    bracket_F,
    bracket_norm,
    bracket_smoothness,
    bracket_V,
    commutator_field,
    directional_derivatives,
    dirichlet_ratio,
    extract_field,
)
from .param import (
    QuadQuality,
    SeamlessParameterization,
    folded_quads,
    quad_mesh,
    quad_quality,
    quad_symmetry_error,
    seamless_parameterization,
    symmetrize_cross_field,
)
from .spectral import (
    MatchResult,
    SpectralBasis,
    fit_functional_map,
    functional_map,
    functional_map_from_bases,
    functional_map_from_p2p,
    geodesic_errors,
    gradient_field_basis,
    heat_kernel_signature,
    laplace_basis,
    map_quality,
    match,
    match_result,
    mean_geodesic_error,
    p2p_from_functional_map,
    symmetry_map,
    wave_kernel_signature,
    zoomout,
)

try:
    __version__ = _metadata.version("fvf")
except _metadata.PackageNotFoundError:  # a source tree that was never installed
    __version__ = "0+unknown"

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
    if name == "batch":  # the top layer (like cli and viz): imported on first use only
        from importlib import import_module

        return import_module("fvf.batch")
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


__all__ = [
    # meshes and files
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
    "icosphere",
    "jittered_sphere",
    "torus",
    "disk",
    "spot",
    "examples",
    "as_face_field",
    "as_face_function",
    "as_vertex_function",
    "as_mesh",
    # calculus (§3.1)
    "face_areas",
    "vertex_areas",
    "vertex_mass",
    "face_mass",
    "rotation",
    "rotate",
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
    # operators (§3.3, §4.2) and brackets (§3.6, §4.3-4.4)
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
    "bracket_norm",
    "bracket_smoothness",
    "dirichlet_ratio",
    # flows (§3.4-3.5) and transport (§4.5)
    "FunctionalFlow",
    "flow",
    "TransportFlow",
    "upwind_operator",
    "skew_operator",
    "dual_edge_fluxes",
    "Ad",
    "FieldTransport",
    "TransportResult",
    "interpolate",
    "ideal_fluid",
    "fluid_time_step",
    "FluidResult",
    # spectral
    "smallest_eigenpairs",
    "eigen_residuals",
    "SpectralBasis",
    "laplace_basis",
    "gradient_field_basis",
    "functional_map",
    "functional_map_from_bases",
    "map_quality",
    # shape correspondence
    "match",
    "match_result",
    "symmetry_map",
    "MatchResult",
    "heat_kernel_signature",
    "wave_kernel_signature",
    "fit_functional_map",
    "p2p_from_functional_map",
    "functional_map_from_p2p",
    "zoomout",
    "geodesic_errors",
    "mean_geodesic_error",
    # design
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
    "killing_fields",
    "commutator_energy",
    "rescale",
    "rescaling_operator",
    "acap_fields",
    "acap_energy_matrix",
    "vertex_indices",
    "singularities",
    "face_indices",
    "face_singularities",
    "singularity_positions",
    "to_power",
    "from_power",
    "period_jumps",
    "cut_graph",
    "comb",
    "principal_curvatures",
    "rescale_frame",
    "frame_report",
    # subpackages and chapter names
    "chapter",
    "mesh",
    "io",
    "operators",
    "flows",
    "spectral",
    "design",
    "numerics",
    # parameterization and quad meshes
    "param",
    "seamless_parameterization",
    "SeamlessParameterization",
    "quad_mesh",
    "quad_quality",
    "QuadQuality",
    "symmetrize_cross_field",
    "quad_symmetry_error",
    "folded_quads",
    *_errors_all,
    "cancel_close_singularities",
    "separate_close_singularities",
]
