"""Spectral tools: Laplace–Beltrami bases and operators reduced to them (:mod:`.basis`),
functional maps between shapes (:mod:`.fmaps`), and shape correspondence: descriptors
(:mod:`.descriptors`), the functional-map fit with the orientation term (:mod:`.fmap_fit`),
conversions and ZoomOut (:mod:`.zoomout`), the one-call pipeline (:mod:`.correspondence`:
:func:`match`, :func:`match_result`, :func:`symmetry_map`) and map evaluation
(:mod:`.evaluation`). The spectral methods of :func:`fvf.flow` and
:func:`fvf.ideal_fluid` (:mod:`.reduced_flows`) register themselves with their dispatchers
in :mod:`fvf.flows` when this package is imported."""

from . import reduced_flows as _reduced_flows  # noqa: F401 (registers the spectral flow methods)
from .basis import SpectralBasis, gradient_field_basis, laplace_basis
from .correspondence import (
    MatchResult,
    as_prepared_mesh,
    match,
    match_result,
    matching_descriptors,
    symmetry_map,
)
from .descriptors import (
    heat_kernel_signature,
    hks_times,
    mirror_distance,
    wave_kernel_signature,
    wks_energies,
)
from .evaluation import (
    cumulative_error_curve,
    geodesic_distances,
    geodesic_errors,
    mean_geodesic_error,
    orientation_agreement,
)
from .fmap_fit import (
    FunctionalMapEnergy,
    descriptor_operators,
    fit_functional_map,
    laplacian_mask,
    orientation_operators,
)
from .fmaps import functional_map, functional_map_from_bases, map_quality
from .zoomout import (
    farthest_point_samples,
    functional_map_from_p2p,
    nearest_rows,
    p2p_from_functional_map,
    zoomout,
)

__all__ = [
    "SpectralBasis",
    "laplace_basis",
    "gradient_field_basis",
    "functional_map",
    "functional_map_from_bases",
    "map_quality",
    "heat_kernel_signature",
    "wave_kernel_signature",
    "mirror_distance",
    "hks_times",
    "wks_energies",
    "FunctionalMapEnergy",
    "fit_functional_map",
    "descriptor_operators",
    "orientation_operators",
    "laplacian_mask",
    "p2p_from_functional_map",
    "functional_map_from_p2p",
    "nearest_rows",
    "farthest_point_samples",
    "zoomout",
    "MatchResult",
    "match",
    "match_result",
    "symmetry_map",
    "as_prepared_mesh",
    "matching_descriptors",
    "geodesic_distances",
    "geodesic_errors",
    "mean_geodesic_error",
    "cumulative_error_curve",
    "orientation_agreement",
]

#: Names of ``__all__`` that the flat namespace ``fvf`` leaves out (reach them as
#: ``fvf.spectral.name``); every other name here is also ``fvf.name``.
NOT_FLAT: frozenset[str] = frozenset(
    {
        "FunctionalMapEnergy",
        "as_prepared_mesh",
        "cumulative_error_curve",
        "descriptor_operators",
        "farthest_point_samples",
        "geodesic_distances",
        "hks_times",
        "laplacian_mask",
        "matching_descriptors",
        "nearest_rows",
        "orientation_agreement",
        "orientation_operators",
        "wks_energies",
    }
)
