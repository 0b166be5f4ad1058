"""Vector-field transport Ad_{Φ_{v,t}} and interpolation of fields along a flow (§4.5).

The transport of a per-face field u along v is (eq. 67)

    Ad_{Φ_{v,t}} u = exp(t [I_F^V] ad_v) u,   [I_F^V] ad_v : R^{3m} -> R^{3m},

where ad_v (eqs. 62–63, :func:`fvf.ad`) maps a face field to the vertex field
D^F_{[v,w]} X and [I_F^V] averages it back to faces, one coordinate at a time. The
exponential is applied to vectors, never formed. The result is not exactly tangent (ad_v
produces vertex vectors); it is projected onto each face and the removed normal part is
reported.

Direction (measured, docs/notes.md): since d/dt u = [v, u] = ad_v u, eq. (67) carries a
field *against* the flow that :func:`fvf.flow` carries functions along: on the sphere with
v = e_z × x, Ad_{Φ_{v,t}} turns a field by R_z(−t), while Φ_{v,t} f = f ∘ R_z(−t) turns a
function by R_z(+t). Use ``t → −t`` to move a field with a function.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
import scipy.sparse as sp
import scipy.sparse.linalg as sla

from .bracket import ad
from .calculus import vertex_to_face
from .fields import TangentPolicy, as_face_field
from .mesh import TriMesh

__all__ = ["FieldTransport", "Ad", "interpolate", "TransportResult"]


@dataclass(frozen=True)
class TransportResult:
    """Fields transported by :class:`FieldTransport`.

    Attributes
    ----------
    fields : float64 (m, 3) or (T, m, 3)
        Tangent (projected) fields.
    normal_part : float or float64 (T,)
        ‖normal component removed‖ / ‖field before projection‖ (L2, eq. 26).
    """

    fields: np.ndarray
    normal_part: float | np.ndarray


class FieldTransport:
    """The transport generator G = [I_F^V] ad_v of a field v (3m x 3m), kept for reuse.

    Parameters
    ----------
    mesh : TriMesh
    v : array_like (m, 3)
        The field whose flow transports other fields.

    Examples
    --------
    >>> import numpy as np, fvf
    >>> mesh = fvf.icosphere(2)
    >>> v = mesh.project_tangent(np.cross([0, 0, 1.0], mesh.face_centroids))
    >>> T = fvf.FieldTransport(mesh, v)
    >>> bool(np.allclose(T(v, 0.0).fields, v))
    True
    """

    def __init__(self, mesh: TriMesh, v: npt.ArrayLike, tangent: TangentPolicy = "project"):
        self.mesh = mesh
        self.field = as_face_field(mesh, v, "v", tangent)
        I3 = sp.kron(vertex_to_face(mesh), sp.eye_array(3), format="csr")  # (3m, 3n)
        self.generator = (I3 @ ad(mesh, self.field, tangent="ignore")).tocsr()  # (3m, 3m)

    def _project(self, U: np.ndarray) -> tuple[np.ndarray, float]:
        """Per-face projection of (m, 3); returns the field and its relative normal part."""
        N, a = self.mesh.face_normals, self.mesh.face_areas
        normal = np.einsum("ij,ij->i", U, N)
        total = float(np.sqrt(a @ np.einsum("ij,ij->i", U, U)))
        rel = float(np.sqrt(a @ normal**2)) / total if total > 0 else 0.0
        return U - normal[:, None] * N, rel

    def __call__(self, u: npt.ArrayLike, t: float | npt.ArrayLike) -> TransportResult:
        """Ad_{Φ_{v,t}} u for one time or an array of times (eq. 67).

        Parameters
        ----------
        u : array_like (m, 3)
        t : float or array_like (T,)
            Any sign and order; arrays are computed by chaining the group property over
            sorted times.

        Returns
        -------
        TransportResult
        """
        u = as_face_field(self.mesh, u, "u")
        times = np.asarray(t, dtype=float)
        if times.ndim > 1 or not np.isfinite(times).all():
            raise ValueError(f"t must be a finite scalar or 1-D array; got {t!r}")
        scalar = times.ndim == 0
        times = np.atleast_1d(times)
        raw = np.empty((times.size, u.size))
        for sign in (1.0, -1.0):
            pick = np.flatnonzero(sign * times >= 0)
            current, now = u.ravel(), 0.0
            for i in pick[np.argsort(sign * times[pick])]:
                if times[i] != now:
                    current = sla.expm_multiply((times[i] - now) * self.generator, current)
                    now = times[i]
                raw[i] = current
        out, normal = [], []
        for r in raw:
            f, nrm = self._project(r.reshape(-1, 3))
            out.append(f)
            normal.append(nrm)
        if scalar:
            return TransportResult(out[0], normal[0])
        return TransportResult(np.stack(out), np.array(normal))


def Ad(mesh: TriMesh, v: npt.ArrayLike, u: npt.ArrayLike, t: float | npt.ArrayLike) -> np.ndarray:
    """Ad_{Φ_{v,t}} u = exp(t [I_F^V] ad_v) u, projected per face (eq. 67).

    One-off form of :class:`FieldTransport`; returns (m, 3) for a scalar t and (T, m, 3)
    for an array.
    """
    return FieldTransport(mesh, v)(u, t).fields


def interpolate(
    mesh: TriMesh,
    v: npt.ArrayLike,
    u0: npt.ArrayLike,
    u1: npt.ArrayLike,
    t: float | npt.ArrayLike,
) -> np.ndarray:
    """u_t = (1 − t) Ad_{Φ_{v,t}} u_0 + t Ad_{Φ_{v,t−1}} u_1, t ∈ [0, 1] (eq. 68).

    Returns u_0 at t = 0 and u_1 at t = 1 exactly (up to the tangent projection), and in
    between moves features along the flow of v instead of blending them in place (Fig. 12).

    Parameters
    ----------
    v : array_like (m, 3)
    u0, u1 : array_like (m, 3)
    t : float or array_like (T,)
        In [0, 1].

    Returns
    -------
    float64 (m, 3) or (T, m, 3)
    """
    times = np.asarray(t, dtype=float)
    if np.any((times < 0) | (times > 1)):
        raise ValueError(f"interpolation times must lie in [0, 1]; got {t!r}")
    T = FieldTransport(mesh, v)
    u0 = as_face_field(mesh, u0, "u0")
    u1 = as_face_field(mesh, u1, "u1")
    a = T(u0, times).fields
    b = T(u1, times - 1.0).fields
    w = times[..., None, None] if times.ndim else times
    out = (1.0 - w) * a + w * b
    # the endpoints are the inputs themselves (Ad at t = 0 is the identity)
    if times.ndim == 0:
        return u0.copy() if times == 0 else (u1.copy() if times == 1 else out)
    out[times == 0] = u0
    out[times == 1] = u1
    return out
