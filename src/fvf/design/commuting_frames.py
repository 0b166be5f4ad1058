r"""Frames whose flows nearly commute: rescaling both fields of a cross-field frame.

A frame is a pair of per-face fields (u, v), typically the combed fields of a cross field
(``C = fvf.comb(mesh, x, 4)``; u = C[0], v = C[1] = J u). A seamless parameterization
wants positive scalings a, b with **commuting flows**, [a u, b v] = 0: then (a u, b v) are
the coordinate fields ∂_φ, ∂_ψ of local coordinates (φ, ψ), and the dual 1-forms
θ¹ = dφ, θ² = dψ of the frame (θ^i(a u) = δ_{i1}, θ^i(b v) = δ_{i2}) are closed.

The chapter's commutation-guided rescaling (§4.4.1, eqs. 65–66) scales one field against a
fixed one; :func:`rescale_frame` scales both. Writing a = e^s, b = e^t,

.. math::

    e^{-(s+t)} [e^s u, e^t v] = [u, v] + (D_u t)\, v - (D_v s)\, u ,

which is *linear* in (s, t), so the frame is rescaled by one sparse least-squares solve,

.. math::

    \min_{s,t}\ \big\| [u,v] + [\bar v]_\bullet D^V_u t - [\bar u]_\bullet D^V_v s
    \big\|^2_{A_V} + \alpha' \big(\|\nabla s\|^2 + \|\nabla t\|^2\big)
    + \epsilon \big(\|s\|^2_{A_V} + \|t\|^2_{A_V}\big),

summed over the interior vertices off the frame's seam (:func:`seam_vertices`: the cut of
a combed cross field, where the frame jumps; at boundary vertices the discrete bracket of
even constant fields is not zero, the chapter's Theorem 1 holding at interior vertices
only), with [u, v] the commutator vertex field D^F_{[u,v]} X of the mixed bracket (eq. 54,
:func:`fvf.commutator_field`), ū = I_V^F u, v̄ = I_V^F v the fields averaged to vertices,
D^V the vertex directional derivatives (eq. 36), α' = α times the ratio of the mean
diagonals of the two forms (α is dimensionless) and ε = 10⁻⁸ of the same scale (it fixes
the constants, which the bracket does not see). a, b > 0 by construction; they are
normalised to area-weighted mean 1.

When the frame is exactly integrable (Theorem 1 type: u = ∇f/|∇f| and v = J u on a flat
domain, e.g. polar coordinates), the minimiser reproduces the coordinate scalings (for
polar coordinates b ∝ r), up to discretization and the smoothness bias.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import numpy.typing as npt
import scipy.sparse as sp

from ..calculus import div, face_to_vertex, rotate, stiffness, vertex_to_face
from ..errors import FrameError, format_indices
from ..mesh.convert import takes_mesh
from ..mesh.inputs import as_face_field, as_nonnegative, as_vertex_function
from ..mesh.trimesh import TriMesh
from ..numerics.cholesky import Backend, factor_hermitian
from ..numerics.summary import html_repr, short_repr
from ..operators.brackets import commutator_field
from ..operators.directional import D_V
from .nfields import period_jumps

__all__ = [
    "FrameReport",
    "FrameRescaling",
    "frame_report",
    "rescale_frame",
    "seam_vertices",
    "FRAME_ALPHA",
]

#: Default dimensionless smoothness weight α of :func:`rescale_frame`.
FRAME_ALPHA = 1e-2
#: A frame with |u × v| below this times |u||v| on a face is degenerate there.
_PARALLEL_RTOL = 1e-6


@dataclasses.dataclass(frozen=True)
class FrameReport:
    """Commutation and integrability of a scaled frame (a u, b v) (:func:`frame_report`).

    Attributes
    ----------
    bracket_energy : float
        ‖[X, Y]‖²_{A_V} / (⟨|X|²⟩⟨|Y|²⟩) for X = a u, Y = b v: the squared A_V-norm of
        the commutator vertex field (mixed bracket, eq. 54) over interior vertices off the
        seam, divided by the area-weighted means of |X|² and |Y|² over the faces, so that
        it does not change when a, b, u or v is multiplied by a constant (units
        1/length²).
    curl_u, curl_v : float
        Integrability errors of the dual 1-forms θ¹, θ²: ‖curl θ‖_{A_V} / ‖θ‖_{A_F} over
        interior vertices, with the weak curl −div(J θ) (units 1/length; 0 for closed
        forms, i.e. for a frame of coordinate fields).
    seam_vertices : int
        Vertices left out of both measures: those on an edge across which u turns by
        more than 45° (:func:`seam_vertices`; the cut of a combed cross field, where the
        frame jumps and no scaling can make it commute).
    """

    __repr__ = short_repr  # arrays by dtype and shape
    _repr_html_ = html_repr  # a table in Jupyter

    bracket_energy: float
    curl_u: float
    curl_v: float
    seam_vertices: int


@dataclasses.dataclass(frozen=True)
class FrameRescaling:
    """The result of :func:`rescale_frame`; unpacks as ``a, b = result``.

    Attributes
    ----------
    a, b : float64 (n,)
        Positive vertex scalings (area-weighted mean 1).
    before, after : FrameReport
        :func:`frame_report` of (u, v) and of (a u, b v).
    """

    __repr__ = short_repr  # arrays by dtype and shape
    _repr_html_ = html_repr  # a table in Jupyter

    a: np.ndarray
    b: np.ndarray
    before: FrameReport
    after: FrameReport

    def __iter__(self):
        return iter((self.a, self.b))


def _check_frame(
    mesh: TriMesh, u: npt.ArrayLike, v: npt.ArrayLike | None
) -> tuple[np.ndarray, np.ndarray]:
    u = as_face_field(mesh, u, "u")
    v = rotate(mesh, u) if v is None else as_face_field(mesh, v, "v")
    cross = np.abs(np.einsum("ij,ij->i", np.cross(u, v), mesh.face_normals))
    size = np.linalg.norm(u, axis=1) * np.linalg.norm(v, axis=1)
    bad = np.flatnonzero(~(cross > _PARALLEL_RTOL * size) | (size == 0))
    if bad.size:
        raise FrameError(
            f"u and v are zero or parallel at faces {format_indices(bad)}, so they do not "
            "form a frame there. Fix: pass the combed fields of a cross field "
            "(C = fvf.comb(mesh, x, 4); u, v = C[0], C[1]) with no zero vectors."
        )
    return u, v


def seam_vertices(mesh: TriMesh, u: np.ndarray) -> np.ndarray:
    """Vertices on an edge across which u turns by more than 45° relative to transport.

    For the combed fields of a cross field these are the cut's vertices (where the frame
    is discontinuous: period jump ≠ 0 as a 4-field), bool (n,).
    """
    jumps = period_jumps(mesh, u, 4)
    seam = np.zeros(mesh.n_vertices, dtype=bool)
    seam[mesh.edges[jumps != 0].ravel()] = True
    return seam


def _measured(mesh: TriMesh, u: np.ndarray) -> np.ndarray:
    """Vertices the frame measures are taken over: interior and off the seam, bool (n,)."""
    keep = ~seam_vertices(mesh, u)
    keep[mesh.boundary_vertices] = False
    return keep


def _coframe(mesh: TriMesh, X: np.ndarray, Y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The dual 1-forms (as per-face vectors) of the frame (X, Y): θ^i(X_j) = δ_ij."""
    x, y = mesh.to_local(X), mesh.to_local(Y)
    det = x[:, 0] * y[:, 1] - x[:, 1] * y[:, 0]
    t1 = np.stack([y[:, 1], -y[:, 0]], axis=1) / det[:, None]
    t2 = np.stack([-x[:, 1], x[:, 0]], axis=1) / det[:, None]
    return mesh.from_local(t1), mesh.from_local(t2)


def _curl_error(mesh: TriMesh, theta: np.ndarray, inner: np.ndarray) -> float:
    curl = -(div(mesh) @ rotate(mesh, theta).ravel())
    num = np.sqrt(mesh.vertex_areas[inner] @ curl[inner] ** 2)
    return float(num / np.sqrt(mesh.face_areas @ (theta * theta).sum(1)))


@takes_mesh
def frame_report(
    mesh: TriMesh,
    u: npt.ArrayLike,
    v: npt.ArrayLike | None = None,
    a: npt.ArrayLike | None = None,
    b: npt.ArrayLike | None = None,
) -> FrameReport:
    """Bracket energy and integrability error of the frame (a u, b v).

    Parameters
    ----------
    mesh : TriMesh
    u, v : array_like, float (m, 3)
        The frame (v defaults to J u), non-parallel and non-zero on every face.
    a, b : array_like, float (n,), optional
        Vertex scalings (default 1), applied on faces through I_F^V.

    Returns
    -------
    FrameReport

    Raises
    ------
    FrameError
        u and v zero or parallel on some faces.
    """
    u, v = _check_frame(mesh, u, v)
    n = mesh.n_vertices
    a = np.ones(n) if a is None else as_vertex_function(mesh, a, "a")
    b = np.ones(n) if b is None else as_vertex_function(mesh, b, "b")
    P = vertex_to_face(mesh)
    X, Y = (P @ a)[:, None] * u, (P @ b)[:, None] * v
    keep = _measured(mesh, u)
    A = np.where(keep, mesh.vertex_areas, 0.0)
    sx, sy = np.abs(X).max(), np.abs(Y).max()
    c = commutator_field(mesh, X / sx, Y / sy)  # the bracket is bilinear: no overflow
    Af = mesh.face_areas
    size = (Af @ (X / sx) ** 2).sum() * (Af @ (Y / sy) ** 2).sum() / Af.sum() ** 2
    energy = float(A @ (c * c).sum(1)) / size
    t1, t2 = _coframe(mesh, X, Y)
    return FrameReport(
        energy,
        _curl_error(mesh, t1, keep),
        _curl_error(mesh, t2, keep),
        int(seam_vertices(mesh, u).sum()),
    )


def _frame_system(
    mesh: TriMesh, u: np.ndarray, v: np.ndarray, alpha: float
) -> tuple[sp.csr_array, np.ndarray]:
    """Normal equations K [s; t] = r of the log-scaling least squares (module docstring)."""
    n = mesh.n_vertices
    I = face_to_vertex(mesh)
    ub, vb = I @ u, I @ v  # (n, 3)
    rows = np.arange(3 * n)
    cols = np.repeat(np.arange(n), 3)

    def times(field):  # [field]•: (3n, n), a vertex function f ↦ f · field (vertex-major)
        return sp.csr_array((field.ravel(), (rows, cols)), shape=(3 * n, n))

    Pt = (times(vb) @ D_V(mesh, u, tangent="ignore")).tocsr()
    Ps = (-(times(ub) @ D_V(mesh, v, tangent="ignore"))).tocsr()
    c = commutator_field(mesh, u, v).ravel()
    fit = np.where(_measured(mesh, u), mesh.vertex_areas, 0.0)
    M = sp.diags_array(np.repeat(fit, 3))
    J = sp.hstack([Ps, Pt]).tocsr()
    G = (J.T @ M @ J).tocsr()
    W = stiffness(mesh)
    mass = mesh.vertex_areas
    gscale = float(np.mean(G.diagonal())) or 1.0
    wscale = float(np.mean(W.diagonal())) or 1.0
    mscale = float(np.mean(mass))
    reg = alpha * gscale / wscale
    eps = 1e-8 * gscale / mscale
    K = G + sp.block_diag([reg * W + eps * sp.diags_array(mass)] * 2)
    rhs = -(J.T @ (M @ c))
    return sp.csr_array(K), rhs


@takes_mesh
def rescale_frame(
    mesh: TriMesh,
    u: npt.ArrayLike,
    v: npt.ArrayLike | None = None,
    *,
    alpha: float = FRAME_ALPHA,
    backend: Backend = "auto",
) -> FrameRescaling:
    """Positive scalings a, b making the flows of a u and b v nearly commute (§4.4.1).

    Parameters
    ----------
    mesh : TriMesh
    u, v : array_like, float (m, 3)
        The frame: typically the combed fields of a cross field, u = C[0], v = C[1]
        (:func:`fvf.comb`); v defaults to J u. Across the cut of a combed field the frame
        jumps; the bracket there is what no scaling removes.
    alpha : float
        Dimensionless smoothness weight α ≥ 0 of log a and log b (module docstring).
    backend : {"auto", "cholmod", "cvxopt", "cholespy", "scipy"}
        Sparse factorization of the (2n, 2n) normal equations.

    Returns
    -------
    FrameRescaling
        ``a``, ``b`` float64 (n,) > 0 on vertices (unpack as ``a, b = ...``), and the
        :class:`FrameReport` before and after.

    Raises
    ------
    FrameError
        u and v zero or parallel on some faces.
    ParameterError
        alpha negative or not finite.

    Notes
    -----
    One sparse symmetric positive definite solve of size 2n (module docstring). The
    bracket energy after is not guaranteed to be below the one before (the model is the
    continuous product rule; the discrete bracket follows it up to discretization error),
    so both are returned; ``tests/design/test_commuting_frames.py`` measures the decrease.
    """
    alpha = as_nonnegative(alpha, "alpha")
    u, v = _check_frame(mesh, u, v)
    K, rhs = _frame_system(mesh, u, v, alpha)
    st = factor_hermitian(K, backend, solves="few").solve(rhs)
    n = mesh.n_vertices
    A = mesh.vertex_areas
    s, t = st[:n], st[n:]
    a, b = np.exp(s - s.max()), np.exp(t - t.max())
    a, b = a * A.sum() / (A @ a), b * A.sum() / (A @ b)
    return FrameRescaling(a, b, frame_report(mesh, u, v), frame_report(mesh, u, v, a, b))
