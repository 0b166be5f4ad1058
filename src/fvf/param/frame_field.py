r"""The frame a parameterization fits: a cross field and the scaling of its two directions.

The cross field is designed by :func:`fvf.design_field` (n = 4): curvature-aligned by
default, or the smoothest one (:mod:`fvf.design.nfields`). The curvature-aligned default
is designed at the scale of the quads: on the connection whose holonomy is the angle
defect smoothed over the target edge length h (``curvature_smoothing=h``,
:mod:`fvf.design.holonomy`), with the principal directions diffused over
:data:`ALIGN_SMOOTHING` · h (``align_smoothing``), so that curvature concentrated below
one quad edge (spikes, pinches, the principal directions of scan noise) forces no cone
that no integer grid of edge h could place. Its cones are then measured against the same
turned connection (:func:`default_connection_rotations`). Its combed representative u and
v = J u (:mod:`fvf.param.cutmesh`) are then scaled per face, X = (a/h) u, Y = (b/h) v, h
the target edge length. Two scalings are offered:

* ``"fitted"`` (default): a fixed point of "fit, then set a and b to the fitted gradient
  lengths along u and v" (smoothed over uncut neighbours), which removes the part of the
  frame's length that no gradient can follow (:func:`fitted_scale`);
* ``"commuting"``: the commutation-guided rescaling of the chapter (§4.4.1),
  :func:`fvf.rescale_frame`: positive vertex functions a, b minimizing the bracket
  ‖[a u, b v]‖² plus a smoothness term, so that the scaled frame is nearly the coordinate
  frame of a map; averaged to faces (I_F^V). On the cut, where the combed frame jumps,
  a and b are set by the smoothness term alone, so the result depends on where the cut
  runs (a mirror-symmetric field does not give mirror-symmetric scales);
* ``"none"``: a = b = 1.

Both are normalized to Σ_t A_t a_t b_t = Σ_t A_t, which keeps the number of quads.
"""

from __future__ import annotations

from typing import Literal

import numpy as np
import numpy.typing as npt
import scipy.sparse as sp

from ..calculus import vertex_to_face
from ..design.commuting_frames import rescale_frame
from ..design.constrained import design_field
from ..design.holonomy import holonomy_rotations
from ..errors import ParameterError
from ..mesh.convert import takes_mesh
from ..mesh.inputs import as_face_field
from ..mesh.nfield import NField
from ..mesh.trimesh import TriMesh
from ..numerics.progress import ProgressCallback
from .cutmesh import CutMesh

__all__ = [
    "ALIGNMENTS",
    "ALIGN_SMOOTHING",
    "default_connection_rotations",
    "SCALINGS",
    "default_cross_field",
    "unit_cross_field",
    "commuting_scale",
    "fitted_scale",
    "normalized_scale",
]

Alignment = Literal["curvature", "smooth"]
ALIGNMENTS = ("curvature", "smooth")
Scaling = Literal["commuting", "fitted", "none"]
SCALINGS = ("commuting", "fitted", "none")
#: The curvature-aligned default field diffuses its alignment target over this many
#: target edge lengths (spot's irregular vertices 4.20 % at 0, 3.86 % at 1, 3.29 % at 2;
#: ``benchmarks/bench_quads.py``).
ALIGN_SMOOTHING = 2.0


@takes_mesh
def default_cross_field(
    mesh: TriMesh,
    align: Alignment = "curvature",
    edge_length: float | None = None,
    constraints: tuple[np.ndarray, np.ndarray] | None = None,
    progress: ProgressCallback | None = None,
    log_scale: np.ndarray | None = None,
) -> NField:
    """The cross field a parameterization uses by default, float64 (m, 3), unit length.

    Parameters
    ----------
    mesh : TriMesh
    align : {"curvature", "smooth"}
        ``"curvature"``: :func:`fvf.design_field` with ``n=4, align="curvature"`` (smooth,
        aligned with the principal directions where the surface is anisotropic);
        ``"smooth"``: the smoothest cross field (``fvf.design_field(mesh, n=4)``).
    edge_length : float, optional
        With ``align="curvature"``: the target edge length h. The field is then designed
        with ``curvature_smoothing=h`` and ``align_smoothing=ALIGN_SMOOTHING * h``
        (module docstring), and its singularities should be measured with
        :func:`default_connection_rotations`. :func:`fvf.seamless_parameterization`
        passes its h. Ignored with ``align="smooth"``.
    constraints : (int64 (c,), float64 (c, 3)), optional
        Faces and the directions the field is held to there (hard constraints of
        :func:`fvf.design_field`; the sharp features of :mod:`fvf.param.features`).
    progress : callable, optional
        ``(stage, done, total)``: the stages of :func:`fvf.design_field`.
    log_scale : float64 (n,), optional
        With ``align="curvature"`` and ``edge_length``: a conformal scale s per vertex;
        the field is designed for the metric e^{2s} g (:mod:`fvf.param.sizing`).

    Returns
    -------
    NField, float64 (m, 3), n = 4
        One unit representative per face; the cross is {u, J u, −u, −J u}. On a face
        where the designed power vanishes (a cone at its centroid) the direction is the
        face's first basis vector.
    """
    if align not in ALIGNMENTS:
        raise ParameterError(f"align must be one of {ALIGNMENTS}; got {align!r}")
    faces, dirs = constraints if constraints is not None and len(constraints[0]) else (None, None)
    hard = faces is not None
    if align == "smooth":
        u = design_field(mesh, faces, dirs, hard=hard, n=4, progress=progress)
    else:
        h = edge_length
        u = design_field(
            mesh,
            faces,
            dirs,
            hard=hard,
            n=4,
            align="curvature",
            curvature_smoothing=h,
            align_smoothing=None if h is None else ALIGN_SMOOTHING * h,
            progress=progress,
            log_scale=None if h is None else log_scale,
        )
    # a cone at a face's centroid (e.g. by symmetry) makes the power exactly 0 there: any
    # direction is as good as another, take the face's first basis vector
    length = np.linalg.norm(u, axis=1)
    zero = length <= 1e-9 * float(length.max(initial=0.0))
    u[zero] = mesh.face_bases[zero, 0]
    return NField(unit_cross_field(mesh, u), 4)


def default_connection_rotations(
    mesh: TriMesh, align: Alignment, edge_length: float, log_scale: np.ndarray | None = None
) -> np.ndarray | None:
    """The connection the default field of ``align`` is measured against: float64 (E,)
    rotations of the transports (:func:`fvf.design.holonomy.holonomy_rotations` over the
    target edge length, for the metric scaled by ``log_scale``) for ``"curvature"``, None
    (Levi-Civita) for ``"smooth"``."""
    if align != "curvature":
        return None
    return holonomy_rotations(mesh, edge_length, log_scale)


def unit_cross_field(mesh: TriMesh, u: npt.ArrayLike) -> np.ndarray:
    """A user cross field checked (:func:`fvf.as_face_field`) and normalized per face.

    Raises :class:`fvf.FieldValueError` naming the faces where it is zero.
    """
    u = as_face_field(mesh, u, "field")
    length = np.linalg.norm(u, axis=1)
    zero = length <= 1e-12 * max(float(length.max(initial=0.0)), 1e-300)
    if zero.any():
        from ..errors import FieldValueError, format_indices

        raise FieldValueError(
            f"the cross field is zero on faces {format_indices(np.flatnonzero(zero))}; "
            "a parameterization needs a direction on every face (design a field without "
            "zeros, e.g. fvf.seamless_parameterization(mesh) with the default field)"
        )
    return u / length[:, None]


def normalized_scale(mesh: TriMesh, scale: np.ndarray) -> np.ndarray:
    """(a, b) per face, float64 (m, 2), scaled so that Σ_t A_t a_t b_t = Σ_t A_t."""
    A = mesh.face_areas
    return scale / np.sqrt(np.sum(A * scale[:, 0] * scale[:, 1]) / A.sum())


def commuting_scale(mesh: TriMesh, cm: CutMesh, alpha: float | None = None) -> np.ndarray:
    """Per-face (a, b), float64 (m, 2), from :func:`fvf.rescale_frame` of the combed frame.

    The vertex scalings of the chapter's commutation-guided rescaling (§4.4.1) are
    averaged to faces and normalized (:func:`normalized_scale`).
    """
    u = cm.field
    v = np.cross(mesh.face_normals, u)
    a, b = rescale_frame(mesh, u, v) if alpha is None else rescale_frame(mesh, u, v, alpha=alpha)
    P = vertex_to_face(mesh)
    return normalized_scale(mesh, 1.0 / np.stack([P @ a, P @ b], axis=1))


def fitted_scale(
    mesh: TriMesh, cm: CutMesh, gradients: np.ndarray, h: float, smooth: int = 3
) -> np.ndarray:
    """New per-face scales (a, b), float64 (m, 2): fitted gradient lengths along u, v.

    ``gradients`` (m, 2, 2) are the rows (∇s, ∇t) of the current fit in each face's local
    frame. The logs of a = h ∇s·u and b = h ∇t·v (clipped to [1/4, 4]) are averaged
    ``smooth`` times over faces sharing an uncut edge (where the frames' labels agree),
    then normalized (:func:`normalized_scale`).
    """
    c, s = np.cos(cm.angles), np.sin(cm.angles)
    a = (gradients[:, 0, 0] * c + gradients[:, 0, 1] * s) * h
    b = (-gradients[:, 1, 0] * s + gradients[:, 1, 1] * c) * h
    la = np.log(np.clip(a, 0.25, 4.0))
    lb = np.log(np.clip(b, 0.25, 4.0))
    ef = mesh.edge_faces
    ok = (~cm.cut) & (ef >= 0).all(axis=1)
    m = mesh.n_faces
    W = sp.coo_array((np.ones(ok.sum()), (ef[ok, 0], ef[ok, 1])), shape=(m, m))
    W = (W + W.T + sp.eye_array(m)).tocsr()
    W = sp.diags_array(1.0 / W.sum(axis=1)) @ W
    for _ in range(smooth):
        la, lb = W @ la, W @ lb
    return normalized_scale(mesh, np.exp(np.stack([la, lb], axis=1)))
