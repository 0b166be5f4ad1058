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

import warnings
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
import scipy.sparse as sp
import scipy.sparse.linalg as sla

from ..calculus import vertex_to_face
from ..errors import (
    FieldShapeError,
    FlowGrowthWarning,
    FlowOverflowError,
    ParameterError,
    format_indices,
    user_stacklevel,
)
from ..mesh.convert import takes_mesh
from ..mesh.inputs import TangentPolicy, as_face_field, as_growth_limit
from ..mesh.trimesh import TriMesh
from ..numerics.expm import as_times, check_options, expm_action
from ..numerics.progress import ProgressCallback, fraction_reporter, make_progress
from ..numerics.summary import html_repr, short_repr
from ..operators.brackets import ad
from .functional import GROWTH_LIMIT, finite_operator

__all__ = ["FieldTransport", "TransportOperator", "Ad", "interpolate", "TransportResult"]


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

    __repr__ = short_repr  # arrays by dtype and shape
    _repr_html_ = html_repr  # a table in Jupyter

    fields: np.ndarray
    normal_part: float | np.ndarray


def _int32_indices(A):
    """A sparse array with its index arrays in int32 when they fit (less memory traffic)."""
    if A.format not in ("csr", "bsr") or max(A.shape) >= 2**31 or A.indices.size >= 2**31:
        return A
    if A.indices.dtype == np.int32 and A.indptr.dtype == np.int32:
        return A
    idx, ptr = A.indices.astype(np.int32), A.indptr.astype(np.int32)
    if A.format == "bsr":
        return sp.bsr_array((A.data, idx, ptr), shape=A.shape, blocksize=A.blocksize)
    return sp.csr_array((A.data, idx, ptr), shape=A.shape)


class TransportOperator(sla.LinearOperator):
    """G = (I_F^V ⊗ I_3) ad_v (3m x 3m) applied as its two sparse factors, never formed.

    ``G @ x`` is ``ad_v @ x`` (3n,) followed by the face mean I_F^V (m, n) of each of the
    three coordinates; ``G.T @ y`` (used by the norm estimates of
    :func:`scipy.sparse.linalg.expm_multiply`) is the transpose of both, with ad_vᵀ built
    on first use. Products are counted in columns: ``n_matvec`` for G, ``n_rmatvec`` for
    Gᵀ (:meth:`reset_counts` sets both to 0).

    Attributes
    ----------
    ad : sparse (3n, 3m)
        ad_v (:func:`fvf.ad`), block sparse with int32 indices.
    vertex_to_face : sparse (m, n)
        I_F^V.
    norm_inf : float
        An upper bound on ‖G‖_∞ (that of ad_v), used to refuse out-of-reach times.
    trace : float
        trace(G), exact: Σ_t Σ_{i ∈ t} (I_F^V)_{ti} trace(ad_v block (i, t)).
    """

    def __init__(self, ad_v: sp.sparray, vertex_to_face_: sp.sparray):
        m, n = vertex_to_face_.shape
        if ad_v.shape != (3 * n, 3 * m):
            raise FieldShapeError(f"ad_v has shape {ad_v.shape}; expected {(3 * n, 3 * m)}")
        super().__init__(np.dtype(np.float64), (3 * m, 3 * m))
        if ad_v.format != "bsr" or ad_v.blocksize != (3, 3):
            ad_v = sp.bsr_array(ad_v, blocksize=(3, 3))
        self.ad = _int32_indices(ad_v)
        self.vertex_to_face = _int32_indices(sp.csr_array(vertex_to_face_))
        self._ad_T: sp.sparray | None = None
        self.n_matvec = 0
        self.n_rmatvec = 0
        # trace(G) = Σ_{t,k} Σ_i P[t, i] ad[3i+k, 3t+k]: the traces of ad's 3 x 3 blocks
        # (block row i, block column t) weighted by P[t, i].
        A = self.ad
        block_tr = np.einsum("bkk->b", A.data)
        tr = sp.csr_array((block_tr, A.indices, A.indptr), shape=(n, m))
        self.trace = float(self.vertex_to_face.multiply(tr.T).sum())
        # ‖G‖_∞ ≤ ‖ad_v‖_∞ (I_F^V averages: non-negative rows summing to 1)
        self.norm_inf = float(abs(A).sum(axis=1).max()) if A.nnz else 0.0

    def reset_counts(self) -> None:
        self.n_matvec = self.n_rmatvec = 0

    def _matvec(self, x):
        self.n_matvec += 1
        n = self.vertex_to_face.shape[1]
        y = self.ad @ np.ravel(x)
        return (self.vertex_to_face @ y.reshape(n, 3)).ravel()

    def _matmat(self, X):
        X = np.asarray(X)
        k = X.shape[1]
        self.n_matvec += k
        n = self.vertex_to_face.shape[1]
        Y = self.ad @ X  # (3n, k), rows 3i + c
        return (self.vertex_to_face @ Y.reshape(n, 3 * k)).reshape(-1, k)

    def _adT(self):
        if self._ad_T is None:
            self._ad_T = _int32_indices(self.ad.T)
        return self._ad_T

    def _rmatvec(self, x):
        self.n_rmatvec += 1
        m = self.vertex_to_face.shape[0]
        z = self.vertex_to_face.T @ np.ravel(x).reshape(m, 3)
        return self._adT() @ z.ravel()

    def _rmatmat(self, X):
        X = np.asarray(X)
        k = X.shape[1]
        self.n_rmatvec += k
        m = self.vertex_to_face.shape[0]
        Z = self.vertex_to_face.T @ X.reshape(m, 3 * k)  # (n, 3k)
        return self._adT() @ Z.reshape(-1, k)

    def toarray(self) -> sp.csr_array:
        """G formed as a sparse (3m, 3m) CSR array (about 117 entries per face)."""
        I3 = sp.kron(self.vertex_to_face, sp.eye_array(3), format="csr")
        return (I3 @ self.ad).tocsr()


class FieldTransport:
    """The transport generator G = [I_F^V] ad_v of a field v (3m x 3m), kept for reuse.

    G is applied as the composition of its two sparse factors (:class:`TransportOperator`,
    ``self.operator``) and its exponential action computed by :func:`fvf.numerics.expm.expm_action`
    (Krylov with incomplete orthogonalization in the face-area inner product; all times in
    one pass) or, with ``method="expm_multiply"``, by
    :func:`scipy.sparse.linalg.expm_multiply` with the exact trace. Decided by measurement
    (one thread, spot mesh refined to 1.5M faces; ``benchmarks/bench_apps.py``): forming G =
    (I_F^V ⊗ I_3) ad_v takes 3.4-5 s and 2.0 GB with int32 indices (2.7 GB with int64; 117
    entries per face), and one product with it 0.25-0.35 s, against 0.2-0.25 s for the two
    factors, which hold 0.38 GB (ad_v, 81 entries per face, int32 block indices, and I_F^V)
    plus about as much for ad_vᵀ, which the 1-norm estimates of expm_multiply need. At 94k
    faces a product with the formed G is 3-4x slower (27 ms vs 6 ms, cache effects). So G is
    not built; ``self.generator`` still returns it, formed on first access.

    Parameters
    ----------
    mesh : TriMesh
    v : array_like (m, 3)
        The field whose flow transports other fields.
    tangent : {"project", "raise", "ignore"}
        What to do with a normal component of v.
    method : {"auto", "krylov", "expm_multiply"}
        Exponential action (see :func:`fvf.numerics.expm.expm_action`).
    tol : float
        Its target relative error (default 1e-10).
    growth_limit : float
        Warn (:class:`~fvf.errors.FlowGrowthWarning`) when a transported field's L2 norm
        (eq. 26) exceeds this multiple of the input's (observed, after the computation).
    progress : None, bool or callable
        ``True`` for a tqdm bar, or a callback ``(stage, done, total)``
        (:mod:`fvf.numerics.progress`; stage ``"transport"``, done of 1000).

    Attributes
    ----------
    operator : TransportOperator
        G as a linear operator; ``operator.n_matvec`` / ``operator.n_rmatvec`` count the
        products with G and Gᵀ (columns) made so far (Gᵀ only by the norm estimates
        inside ``expm_multiply``).
    stats : dict
        Statistics of the last call (:func:`fvf.numerics.expm.expm_action`'s ``info``).

    Examples
    --------
    >>> import numpy as np, fvf
    >>> mesh = fvf.icosphere(2)
    >>> v = mesh.project_tangent(np.cross([0, 0, 1.0], mesh.face_centroids))
    >>> T = fvf.FieldTransport(mesh, v)
    >>> bool(np.allclose(T(v, 0.0).fields, v))
    True
    """

    @takes_mesh
    def __init__(
        self,
        mesh: TriMesh,
        v: npt.ArrayLike,
        tangent: TangentPolicy = "project",
        *,
        method: str = "auto",
        tol: float = 1e-10,
        growth_limit: float = GROWTH_LIMIT,
        progress: bool | ProgressCallback | None = None,
    ):
        method, tol = check_options(method, tol)
        make_progress(progress)  # a bad value fails here, not at the first call
        self.progress = progress
        self.method = method
        self.tol = float(tol)
        self.growth_limit = as_growth_limit(growth_limit)
        self.stats: dict = {}
        self.mesh = mesh
        self.field = as_face_field(mesh, v, "v", tangent)
        self.operator = TransportOperator(
            finite_operator(lambda: ad(mesh, self.field, tangent="ignore"), self.field),
            vertex_to_face(mesh),
        )
        self._generator: sp.csr_array | None = None

    @property
    def generator(self) -> sp.csr_array:
        """G formed as a sparse (3m, 3m) CSR array, built on first access (memory: ~1.8 kB
        per face; the transport itself does not use it)."""
        if self._generator is None:
            self._generator = self.operator.toarray()
        return self._generator

    def _project(self, U: np.ndarray) -> tuple[np.ndarray, float]:
        """Per-face projection of (m, 3); returns the field and its relative normal part."""
        N, a = self.mesh.face_normals, self.mesh.face_areas
        normal = np.einsum("ij,ij->i", U, N)
        total = float(np.sqrt(a @ np.einsum("ij,ij->i", U, U)))
        rel = float(np.sqrt(a @ normal**2)) / total if total > 0 else 0.0
        return U - normal[:, None] * N, rel

    def _check_growth(self, u: np.ndarray, raw: np.ndarray, times: np.ndarray) -> None:
        """Raise on inf/NaN; warn when ‖Ad u‖/‖u‖ (face-area L2) exceeds growth_limit."""
        if not np.isfinite(raw).all():
            raise FlowOverflowError(
                f"the transport overflowed to inf/NaN by t={times[np.abs(times).argmax()]:g}: "
                "[I_F^V] ad_v is not normal and its exponential grew without bound; use "
                "shorter times or a smoother field/mesh"
            )
        a = np.repeat(self.mesh.face_areas, 3)
        n0 = float(np.sqrt(a @ (u.ravel() ** 2)))
        if n0 == 0:
            return
        norms = np.sqrt((raw * raw) @ a)  # (T,)
        k = int(np.argmax(norms))
        growth = float(norms[k]) / n0
        if growth <= self.growth_limit:
            return
        size = np.sqrt((raw[k].reshape(-1, 3) ** 2).sum(1))  # (m,) |Ad u| per face
        faces = np.sort(np.argsort(size, kind="stable")[-8:][::-1])
        warnings.warn(
            f"the transport to t={times[k]:g} grew the field's L2 norm {growth:.3g}x (limit "
            f"{self.growth_limit:g}); the transported field is largest in faces "
            f"{format_indices(faces)}. The continuous transport changes norms only by the "
            "flow's stretching (strongly near sinks of a compressible v); growth this large "
            "usually comes from the non-normal discrete generator (docs/notes.md). Use "
            "shorter times or a smoother field/mesh; pass growth_limit=np.inf to silence this.",
            FlowGrowthWarning,
            stacklevel=user_stacklevel(),
        )

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

        Raises
        ------
        FlowOverflowError
            The transported field overflowed to inf/NaN, or the time is out of reach.

        Warns
        -----
        FlowGrowthWarning
            When the transported field's L2 norm exceeds ``growth_limit`` times the
            input's, naming the faces where it is largest.
        """
        u = as_face_field(self.mesh, u, "u")
        times, scalar = as_times(t)
        if times.size == 0:  # no times, no frames (as fvf.flow)
            return TransportResult(np.empty((0,) + u.shape), np.empty(0))
        raw, self.stats = expm_action(
            self.operator,
            u.ravel(),
            times,
            tol=self.tol,
            inner=np.repeat(self.mesh.face_areas, 3),
            skew=False,
            method=self.method,  # expm_action checks the name
            progress=fraction_reporter(self.progress, "transport"),
            return_info=True,
        )
        raw = raw.reshape(times.size, -1)  # (T, 3m)
        self._check_growth(u, raw, times)
        out, normal = [], []
        for r in raw:
            f, nrm = self._project(r.reshape(-1, 3))
            out.append(f)
            normal.append(nrm)
        if scalar:
            return TransportResult(out[0], normal[0])
        return TransportResult(np.stack(out), np.array(normal))


@takes_mesh
def Ad(
    mesh: TriMesh,
    v: npt.ArrayLike,
    u: npt.ArrayLike,
    t: float | npt.ArrayLike,
    *,
    growth_limit: float = GROWTH_LIMIT,
) -> np.ndarray:
    """Ad_{Φ_{v,t}} u = exp(t [I_F^V] ad_v) u, projected per face (eq. 67).

    One-off form of :class:`FieldTransport` (see there for ``growth_limit``, the warning
    and the errors); returns (m, 3) for a scalar t and (T, m, 3) for an array.
    """
    return FieldTransport(mesh, v, growth_limit=growth_limit)(u, t).fields


@takes_mesh
def interpolate(
    mesh: TriMesh,
    v: npt.ArrayLike,
    u0: npt.ArrayLike,
    u1: npt.ArrayLike,
    t: float | npt.ArrayLike,
    *,
    growth_limit: float = GROWTH_LIMIT,
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
    growth_limit : float
        As for :class:`FieldTransport`.

    Returns
    -------
    float64 (m, 3) or (T, m, 3)
    """
    flat, scalar = as_times(t)
    if np.any((flat < 0) | (flat > 1)):
        raise ParameterError(f"interpolation times must lie in [0, 1]; got {t!r}")
    T = FieldTransport(mesh, v, growth_limit=growth_limit)
    u0 = as_face_field(mesh, u0, "u0")
    u1 = as_face_field(mesh, u1, "u1")
    out = np.empty((flat.size,) + u0.shape)
    # the endpoints are the inputs themselves (Ad at t = 0 is the identity): no flow
    out[flat == 0] = u0
    out[flat == 1] = u1
    inner = (flat > 0) & (flat < 1)
    if inner.any():
        s = flat[inner][:, None, None]
        a = T(u0, flat[inner]).fields  # (k, m, 3)
        b = T(u1, flat[inner] - 1.0).fields
        out[inner] = (1.0 - s) * a + s * b
    return out[0] if scalar else out
