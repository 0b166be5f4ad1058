"""Field design: one home for every way of making a tangent field.

- :mod:`.connection`: face connection Laplacians and the smoothest fields (Knöppel et al.
  2013).
- :mod:`.constrained`: fields from sparse hard or soft direction constraints.
- :mod:`.killing`: Killing fields (Azencot et al. 2013).
- :mod:`.symmetric`: fields consistent with a self-map (Azencot et al. 2017).
- :mod:`.commuting`: commutation-guided rescaling and as-commuting-as-possible fields (§4.4).
- :mod:`.indices`: indices and singularities of designed fields (Poincaré–Hopf).
- :mod:`.commuting_frames`: frames (u, v) rescaled so that their flows nearly commute.
- :mod:`.alignment`: alignment targets (principal curvature directions, user fields).
- :mod:`.nfields`: N-direction fields: power representation, period jumps, cut graph,
  combing.

A new design method goes into a module of its own here and is exported below.
"""

from .cancellation import cancel_close_singularities, separate_close_singularities
from .commuting import acap_energy_matrix, acap_fields, rescale, rescaling_operator
from .commuting_frames import FrameReport, FrameRescaling, frame_report, rescale_frame
from .connection import (
    connection_energy,
    connection_laplacian,
    connection_mass,
    real_connection_laplacian,
    restrict_to_tangent,
    smoothest_fields,
    tangent_basis_matrix,
)
from .constrained import closest_faces, design_field, locate_points
from .indices import (
    face_indices,
    face_singularities,
    singularities,
    singularity_positions,
    vertex_indices,
)
from .killing import commutator_energy, killing_fields
from .nfields import (
    CutGraph,
    all_directions,
    comb,
    cut_graph,
    from_power,
    period_jumps,
    to_power,
)
from .symmetric import consistency_residual, map_consistent_field

__all__ = [
    "connection_laplacian",
    "connection_mass",
    "connection_energy",
    "real_connection_laplacian",
    "restrict_to_tangent",
    "tangent_basis_matrix",
    "smoothest_fields",
    "design_field",
    "locate_points",
    "closest_faces",
    "killing_fields",
    "commutator_energy",
    "map_consistent_field",
    "consistency_residual",
    "rescaling_operator",
    "rescale",
    "acap_energy_matrix",
    "acap_fields",
    "vertex_indices",
    "singularities",
    "face_indices",
    "face_singularities",
    "singularity_positions",
    "to_power",
    "from_power",
    "all_directions",
    "period_jumps",
    "CutGraph",
    "cut_graph",
    "comb",
    "rescale_frame",
    "frame_report",
    "FrameRescaling",
    "FrameReport",
    "cancel_close_singularities",
    "separate_close_singularities",
]

#: Names of ``__all__`` that the flat namespace ``fvf`` leaves out (reach them as
#: ``fvf.design.name``); every other name here is also ``fvf.name``.
NOT_FLAT: frozenset[str] = frozenset(
    {
        "CutGraph",
        "FrameReport",
        "FrameRescaling",
        "all_directions",
        "consistency_residual",
    }
)
