"""The quad mesh of a cross field: seamless parameterization, then integer-grid extraction."""

from __future__ import annotations

from typing import Any

import numpy as np
import numpy.typing as npt

from ..errors import ParameterError, QuadExtractionError
from ..mesh.convert import takes_mesh
from ..mesh.trimesh import TriMesh
from ..numerics.progress import make_progress
from .extraction import extract_quads
from .frame_field import Alignment
from .quad_folds import MAX_RINGS, STEPS_PER_RING, untangle_quads, warn_folded
from .seamless import SeamlessParameterization, seamless_parameterization

__all__ = ["quad_mesh"]


@takes_mesh
def quad_mesh(
    mesh: TriMesh,
    *,
    target_faces: int | None = None,
    field: npt.ArrayLike | None = None,
    edge_length: float | None = None,
    align: Alignment = "curvature",
    return_parameterization: bool = False,
    fold_repair_steps: int = STEPS_PER_RING * (MAX_RINGS + 1),
    **options: Any,
) -> tuple[np.ndarray, np.ndarray] | tuple[np.ndarray, np.ndarray, SeamlessParameterization]:
    """A pure-quad mesh whose edges follow a cross field (the chapter's Fig. 1 pipeline).

    Runs :func:`fvf.seamless_parameterization` and pulls back its integer grid
    (:func:`fvf.param.extraction.extract_quads`): quad vertices at integer points, quad
    edges along integer iso-lines. Quads folded in 3D (normal against the input surface's
    at the quad; :func:`fvf.param.quad_folds.folded_quads`) are then untangled on the
    surface (:func:`fvf.param.quad_folds.untangle_quads`): the corners of the folded quads,
    and a few rings around them when needed, are relaxed tangentially and put back on the
    input surface. Those vertices leave their integer uv points (on spot at 1500 quads and
    armadillo at 8000, four vertices each, by up to 0.57 of the median quad edge); the
    connectivity is unchanged.

    Parameters
    ----------
    mesh : TriMesh
        Closed, one component, orientable (else :class:`fvf.ParameterizationInputError`).
    target_faces : int, optional
        Approximate number of quads (default m / 10); exclusive with ``edge_length``.
    field : array_like (m, 3), optional
        Cross field, one representative tangent vector per face (default: curvature
        aligned, or the smoothest with ``align="smooth"``).
    edge_length : float, optional
        Target quad edge length instead of a count.
    align : {"curvature", "smooth"}
    return_parameterization : bool
        Also return the :class:`fvf.SeamlessParameterization`.
    fold_repair_steps : int
        Relaxation steps at most for untangling folded quads (0: detect and warn only).
    **options
        Passed to :func:`fvf.seamless_parameterization` (``scale``, ``rounding_batch``,
        ``scale_iterations``, ``stiffening_iterations``, ``cone_cancel_radius``).

    Returns
    -------
    vertices : float64 (k, 3)
        On the input surface: at the integer points of the parameterization, except the
        vertices moved by the untangling of folded quads.
    quads : int64 (q, 4)
        Counter-clockwise about the input's outward normal. On a closed input: a closed,
        manifold, pure-quad mesh with the input's Euler characteristic (checked).
    parameterization : SeamlessParameterization
        Only with ``return_parameterization=True``.

    Raises
    ------
    QuadExtractionError
        uv triangles stay flipped after stiffening (the faces are named), or the grid does
        not close into quads (target too coarse for the topology). No broken mesh is
        returned.
    ParameterError
        ``fold_repair_steps`` is negative or not an integer.

    Warns
    -----
    FoldedQuadWarning
        Quads stay folded in 3D after the untangling (the quads are named; the mesh is
        returned as it is: closed and manifold, with those quads facing inwards). Fix: ask
        for more quads.
    """
    if (
        isinstance(fold_repair_steps, bool)
        or not isinstance(fold_repair_steps, int | np.integer)
        or fold_repair_steps < 0
    ):
        raise ParameterError(
            f"fold_repair_steps must be a non-negative integer; got {fold_repair_steps!r}"
        )
    param = seamless_parameterization(
        mesh,
        field=field,
        target_faces=target_faces,
        edge_length=edge_length,
        align=align,
        **options,
    )
    report = make_progress(options.get("progress"))
    report("quad extraction", 0, 1)
    qm = extract_quads(mesh, param.uv)
    repair = untangle_quads(
        mesh, qm.vertices, qm.quads, qm.vertex_face, max_steps=int(fold_repair_steps)
    )
    warn_folded(repair)
    report("quad extraction", 1, 1)
    V = np.ascontiguousarray(repair.vertices, dtype=np.float64)
    Q = np.ascontiguousarray(qm.quads, dtype=np.int64)
    if Q.shape[0] == 0:  # pragma: no cover - extract_quads raises first
        raise QuadExtractionError("no quads were extracted")
    return (V, Q, param) if return_parameterization else (V, Q)
