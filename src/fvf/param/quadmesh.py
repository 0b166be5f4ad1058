"""The quad mesh of a cross field: seamless parameterization, then integer-grid extraction."""

from __future__ import annotations

from typing import Any

import numpy as np
import numpy.typing as npt

from ..errors import QuadExtractionError
from ..mesh.convert import takes_mesh
from ..mesh.trimesh import TriMesh
from ..numerics.progress import make_progress
from .extraction import extract_quads
from .frames import Alignment
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
    **options: Any,
) -> tuple[np.ndarray, np.ndarray] | tuple[np.ndarray, np.ndarray, SeamlessParameterization]:
    """A pure-quad mesh whose edges follow a cross field (the chapter's Fig. 1 pipeline).

    Runs :func:`fvf.seamless_parameterization` and pulls back its integer grid
    (:func:`fvf.param.extraction.extract_quads`): quad vertices at integer points, quad
    edges along integer iso-lines.

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
    **options
        Passed to :func:`fvf.seamless_parameterization` (``scale``, ``rounding_batch``,
        ``scale_iterations``, ``stiffening_iterations``, ``cone_cancel_radius``).

    Returns
    -------
    vertices : float64 (k, 3)
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
    """
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
    report("quad extraction", 1, 1)
    V = np.ascontiguousarray(qm.vertices, dtype=np.float64)
    Q = np.ascontiguousarray(qm.quads, dtype=np.int64)
    if Q.shape[0] == 0:  # pragma: no cover - extract_quads raises first
        raise QuadExtractionError("no quads were extracted")
    return (V, Q, param) if return_parameterization else (V, Q)
