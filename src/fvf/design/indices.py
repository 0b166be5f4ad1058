"""Singularities of tangent vector fields: the discrete index (Poincaré–Hopf).

Two discretisations are covered.

*Per-face fields* u, shape (m, 3) (the PC vector fields of the chapter, e.g. a gradient,
``J grad f``, a flow's velocity): the field is constant on each face, so it can only wind
around a vertex. :func:`vertex_indices` measures, for every interior vertex, how much the
field turns relative to discrete Levi-Civita transport as one walks once around the
vertex's fan, and :func:`singularities` lists the vertices where it turns.

*Per-vertex fields* U, shape (n, 3) (e.g. the commutator field ``D^F_{[v,w]} X``): the
field is sampled at the corners of each face, so it winds inside faces.
:func:`face_indices` measures the turning of the projected corner vectors around each
triangle, and :func:`face_singularities` lists the faces where it turns.

Conventions
-----------
Angles are measured counter-clockwise about the face normal N (right-hand rule), so a
field that turns counter-clockwise as one walks counter-clockwise around a point has
index +1 (a source, a sink, a centre), a saddle ``(x, -y)`` has index -1 and ``z^2`` has
index +2. On a closed mesh the vertex indices of any per-face field without zero vectors
add up to the Euler characteristic exactly (Poincaré–Hopf); this holds by construction,
see :func:`vertex_indices`.
"""

from __future__ import annotations

import warnings
from typing import TYPE_CHECKING, Literal

import numpy as np
import numpy.typing as npt

from ..errors import (
    FieldShapeError,
    ParameterError,
    ZeroFieldWarning,  # noqa: F401 (re-exported)
    format_indices,
)
from ..mesh.convert import takes_mesh
from ..mesh.geometry import angle_defects, cross_rows
from ..mesh.inputs import (
    TangentPolicy,
    as_face_field,
    as_vertex_function,
    unit_scale,
    vector_rows,
)
from ..mesh.nfield import FROM_FIELD, FromField, field_order

if TYPE_CHECKING:
    from ..mesh.trimesh import TriMesh

__all__ = [
    "ZERO_RTOL",
    "vertex_indices",
    "singularities",
    "face_indices",
    "face_singularities",
    "singularity_positions",
]

#: A vector whose (tangential) length is at most this times the field's largest vector
#: counts as zero: its direction, and hence any angle measured from it, is undefined.
ZERO_RTOL = 1e-10

TWO_PI = 2.0 * np.pi

ZeroPolicy = Literal["raise", "warn"]


def _wrap(d: np.ndarray) -> np.ndarray:
    """Angles wrapped to the half-open interval (-pi, pi]."""
    return np.pi - np.mod(np.pi - d, TWO_PI)


def _check_zero_policy(zero: str) -> None:
    if zero not in ("raise", "warn"):
        raise ParameterError(f"zero must be 'raise' or 'warn'; got {zero!r}")


def _zero_mask(length: np.ndarray, scale: float, rtol: float) -> np.ndarray:
    """True where a vector of the given length counts as zero (everything if scale is 0)."""
    if not (np.isfinite(rtol) and rtol >= 0):
        raise ParameterError(f"zero_rtol must be a non-negative number; got {rtol!r}")
    if not scale > 0.0:
        return np.ones(length.shape, dtype=bool)
    return length <= rtol * scale


def as_connection_rotations(mesh: TriMesh, rotations: npt.ArrayLike) -> np.ndarray:
    """``connection_rotations`` checked: float64 (E,), finite, else
    :class:`fvf.ParameterError` (the angles of
    :func:`fvf.design.holonomy.holonomy_rotations`)."""
    x = np.asarray(rotations, dtype=float)
    if x.shape != (mesh.n_edges,) or not np.isfinite(x).all():
        raise ParameterError(
            f"connection_rotations must be finite, one angle per edge, shape "
            f"({mesh.n_edges},); got shape {x.shape}. Fix: use "
            "fvf.design.holonomy.holonomy_rotations(mesh, length)"
        )
    return x


@takes_mesh
def vertex_indices(
    mesh: TriMesh,
    u: npt.ArrayLike,
    *,
    n: int | FromField = FROM_FIELD,
    zero: ZeroPolicy = "raise",
    zero_rtol: float = ZERO_RTOL,
    tangent: TangentPolicy = "project",
    connection_rotations: npt.ArrayLike | None = None,
) -> np.ndarray:
    r"""Index of a per-face tangent field around every vertex.

    For an interior vertex v with faces t_0, ..., t_{k-1} in counter-clockwise order,

    .. math::

        \operatorname{ind}_v(u) = \frac{1}{2\pi}\Big(\sum_{j} \operatorname{wrap}
        \big(\theta_{t_{j+1}}(e_j) - \theta_{t_j}(e_j)\big) + K_v\Big),
        \qquad K_v = 2\pi - \sum_{t \ni v} \alpha_{t,v},

    where e_j is the edge vector from v along the edge shared by t_j and t_{j+1},
    ``theta_t(e) = atan2(<N_t x e, u_t>, <e, u_t>)`` is the angle of u_t measured
    counter-clockwise from e in face t (so unfolding the hinge keeps e fixed and the
    difference is the turning of u relative to discrete Levi-Civita transport),
    ``wrap`` maps to (-pi, pi], alpha are the corner angles and K_v is the angle defect
    (the holonomy of the transport around v). The bracket is an exact multiple of
    2*pi up to round-off, and is rounded.

    Each interior edge contributes its turning ``+delta`` to one endpoint and
    ``-delta`` to the other (the two walks cross it in opposite directions), so on a
    closed mesh the turnings cancel and ``sum(ind) = sum(K_v) / 2 pi = chi`` exactly
    (discrete Gauss–Bonnet + Poincaré–Hopf). The computation is vectorised: per-edge
    and per-corner terms are accumulated with ``np.bincount``.

    **N-direction fields** (``n = N ≥ 2``; u holds one representative vector per face,
    the other directions being its rotations by 2πj/N): the turning across each edge is
    taken modulo 2π/N, i.e. ``wrap`` is replaced by the shortest rotation between the two
    N-direction sets, ``δ = φ − (2π/N) rint(N φ / 2π)`` with φ the 1-field turning, and
    the index is a multiple of 1/N (``N ind_v`` an integer). The period jumps
    ``rint(N φ / 2π) mod N`` are :func:`fvf.period_jumps`. Poincaré–Hopf holds exactly in
    the same way: the N-indices sum to chi.

    Parameters
    ----------
    mesh : TriMesh
    u : array_like, float (m, 3) or (3m,)
        One tangent vector per face (for n ≥ 2, one representative per face). Only the
        tangential part enters the angles.
    n : int, optional
        Symmetry order N ≥ 1 of the field. Default: the ``n`` of an :class:`fvf.NField`
        (what :func:`fvf.design_field` returns), else 1 (a vector field).
    zero : {"raise", "warn"}
        What to do when some faces have a zero vector (tangential length at most
        ``zero_rtol`` times the largest one; an all-zero field counts as zero
        everywhere). The direction is then undefined, so no loop through such a face
        has an index. ``"raise"`` (default): raise :class:`FieldShapeError` naming the
        faces. ``"warn"``: emit :class:`ZeroFieldWarning` and return 0 at every vertex
        of those faces (a singularity sitting on a zero face is therefore not
        reported; perturb or re-sample the field to locate it).
    zero_rtol : float
        Relative threshold for a zero vector, default :data:`ZERO_RTOL`.
    tangent : {"project", "raise", "ignore"}
        Normal-component policy of :func:`fvf.mesh.inputs.as_face_field`.
    connection_rotations : float (E,), optional
        Angles x_e added to the transport across each edge (``mesh.edges`` order;
        :func:`fvf.design.holonomy.holonomy_rotations`). The turning across e is then
        taken as the shortest rotation relative to the turned transport,
        δ_e = x_e + wrap(φ_e − x_e) (reduced modulo 2π/N), and the index is
        (Σ ±δ_e + K_v)/2π as above. A field that is nearly parallel for the turned
        connection gets its singularities where that connection's holonomy
        K_v − (Gᵀx)_v accumulates, not at every vertex with a large angle defect. The
        indices still sum to chi. Default: none (x = 0).

    Returns
    -------
    ndarray, int64 (n,) for n = 1; float64 (n,) for n ≥ 2
        The index at each vertex; for n ≥ 2 the values k/N (``rint(N * ind)`` gives the
        exact integers k). **Boundary vertices get 0**: no closed loop of faces
        surrounds them, so their index is not defined; a singularity on the boundary
        is therefore not reported, and Poincaré–Hopf (sum = chi) holds only on closed
        meshes.

    Raises
    ------
    FieldShapeError
        Wrong shape, non-finite values, or (``zero="raise"``) zero vectors.

    Notes
    -----
    The turning across an edge is taken as the shortest rotation, so a field that
    turns by more than pi between two adjacent faces is under-resolved and the index
    can be off there; a field that is smooth at the scale of the mesh is fine.

    Examples
    --------
    >>> import fvf
    >>> from fvf.design.indices import vertex_indices
    >>> mesh = fvf.disk(4, 6)
    >>> c = mesh.face_centroids
    >>> int(vertex_indices(mesh, c * [1, -1, 0])[0])  # a saddle at the origin
    -1
    """
    _check_zero_policy(zero)
    order = field_order(u, n, 1, "u")
    u = as_face_field(mesh, u, "u", tangent=tangent)
    X, N, E, EF = mesh.vertices, mesh.face_normals, mesh.edges, mesh.edge_faces
    n = mesh.n_vertices

    # Zero vectors: judged on the tangential part. Angles do not depend on the field's
    # size: scale it to unit size (exactly, by a power of two) so that no product overflows.
    ut = u - np.einsum("ij,ij->i", u, N)[:, None] * N
    ut = ut / unit_scale(ut)
    length = np.sqrt(np.einsum("ij,ij->i", ut, ut))
    is_zero = _zero_mask(length, float(length.max()), zero_rtol)

    interior = np.flatnonzero((EF >= 0).all(axis=1))
    a, b = E[interior, 0], E[interior, 1]
    s0, s1 = EF[interior, 0], EF[interior, 1]  # s0 runs a -> b, s1 runs b -> a
    ev = X[b] - X[a]

    def complex_angle(s: np.ndarray) -> np.ndarray:
        # <e, u> + i <N x e, u>: the direction of u_s relative to e, counter-clockwise.
        us = ut[s]
        return np.einsum("ij,ij->i", ev, us) + 1j * np.einsum("ij,ij->i", cross_rows(N[s], ev), us)

    # Walking counter-clockwise around a, the edge a->b is entered from s1 into s0
    # (in s0 = (a, b, c) the edge a->b is the first edge at corner a); walking around
    # b the same edge is crossed from s0 into s1.
    z = complex_angle(s0) * np.conj(complex_angle(s1))
    x = np.zeros(interior.size)
    if connection_rotations is not None:
        x = as_connection_rotations(mesh, connection_rotations)[interior]
        z = z * np.exp(-1j * x)
    delta = _wrap(np.arctan2(z.imag, z.real))
    if order != 1:  # shortest rotation between the two N-direction sets
        delta = delta - (TWO_PI / order) * np.rint(order * delta / TWO_PI)
    delta = delta + x
    turning = np.bincount(a, weights=delta, minlength=n) - np.bincount(
        b, weights=delta, minlength=n
    )

    index = np.rint(order * (turning + angle_defects(mesh)) / TWO_PI).astype(np.int64)
    index[mesh.boundary_vertices] = 0

    if is_zero.any():
        faces = np.flatnonzero(is_zero)
        verts = np.unique(mesh.faces[faces])
        msg = (
            f"u is (numerically) zero at faces {format_indices(faces)} (tangential length "
            f"<= {zero_rtol:g} times the largest), so its direction, and the index of "
            f"vertices {format_indices(verts)} around them, are undefined"
        )
        if zero == "raise":
            raise FieldShapeError(
                msg + ". Fix: perturb or re-sample the field there, or pass zero='warn' to "
                "get index 0 at those vertices."
            )
        warnings.warn(msg + "; their index was set to 0.", ZeroFieldWarning, stacklevel=2)
        index[verts] = 0
    return index if order == 1 else index / order


@takes_mesh
def singularities(
    mesh: TriMesh,
    u: npt.ArrayLike,
    *,
    n: int | FromField = FROM_FIELD,
    zero: ZeroPolicy = "raise",
    zero_rtol: float = ZERO_RTOL,
    tangent: TangentPolicy = "project",
    connection_rotations: npt.ArrayLike | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Vertices around which a per-face field has a non-zero index.

    Parameters
    ----------
    mesh : TriMesh
    u : array_like, float (m, 3) or (3m,)
        One tangent vector per face (one representative per face for n ≥ 2).
    n : int, optional
        Symmetry order N ≥ 1 (1 vector, 2 line, 4 cross, …). Default: the ``n`` of an
        :class:`fvf.NField` (what :func:`fvf.design_field` returns), else 1.
    zero, zero_rtol, tangent, connection_rotations
        As in :func:`vertex_indices`.

    Returns
    -------
    vertex_ids : ndarray, int64 (s,)
        Sorted ids of the vertices with non-zero index (never boundary vertices).
    indices : ndarray, int64 (s,) for n = 1, float64 (s,) multiples of 1/N for n ≥ 2
        Their indices (:func:`vertex_indices`); on a closed mesh they sum to chi
        (Poincaré–Hopf). On a mesh with boundary, boundary vertices are never reported
        (no loop of faces surrounds them) and the interior indices sum to chi minus the
        boundary's share, which depends on how the field meets the boundary.

    Examples
    --------
    >>> import fvf
    >>> from fvf.design.indices import singularities
    >>> mesh = fvf.disk(4, 6)
    >>> ids, ind = singularities(mesh, mesh.face_centroids * [1, 1, 0])  # a source
    >>> ids.tolist(), ind.tolist()
    ([0], [1])
    """
    index = vertex_indices(
        mesh,
        u,
        n=n,
        zero=zero,
        zero_rtol=zero_rtol,
        tangent=tangent,
        connection_rotations=connection_rotations,
    )
    ids = np.flatnonzero(index).astype(np.int64)
    return ids, index[ids]


def _as_vertex_field(mesh: TriMesh, U: npt.ArrayLike, name: str) -> np.ndarray:
    U = np.asarray(U)
    face_like = U.shape[:1] == (mesh.n_faces,) or U.shape == (3 * mesh.n_faces,)
    hint = " (a face field? this needs one vector per vertex; see vertex_indices)"
    U = vector_rows(U, mesh.n_vertices, name, "vertex", hint if face_like else "")
    return as_vertex_function(mesh, U, name, columns=True)


@takes_mesh
def face_indices(
    mesh: TriMesh,
    U: npt.ArrayLike,
    *,
    zero: ZeroPolicy = "raise",
    zero_rtol: float = ZERO_RTOL,
) -> np.ndarray:
    r"""Index of a per-vertex vector field inside every face.

    The three corner vectors U(v_0), U(v_1), U(v_2) of face t are projected onto the
    face plane (coordinates in :attr:`TriMesh.face_bases`, angles counter-clockwise
    about N_t) and

    .. math::

        \operatorname{ind}_t(U) = \frac{1}{2\pi}\sum_{i=0}^{2}
        \operatorname{wrap}\big(\phi_{i+1} - \phi_i\big), \qquad \phi_3 = \phi_0,

    with ``wrap`` to (-pi, pi], walking the corners in the face's counter-clockwise
    order. The sum is an exact multiple of 2*pi, so the result is -1, 0 or +1 (a face
    cannot resolve a higher index: a ``z^2`` singularity shows up as two +1 faces or
    is missed). Projection onto the plane of the face is the (flat) transport inside
    the face; no curvature term is needed. Unlike :func:`vertex_indices`, the sum over
    faces of a closed mesh equals chi only approximately (the projections onto two
    neighbouring faces are not related by transport), typically exactly for fields
    that are smooth at the mesh scale.

    Parameters
    ----------
    mesh : TriMesh
    U : array_like, float (n, 3) or (3n,)
        One ambient vector per vertex (need not be tangent to anything).
    zero : {"raise", "warn"}
        What to do when a projected corner vector is (numerically) zero, i.e. its
        length in the face plane is at most ``zero_rtol`` times the largest vector
        ``max |U|``. This includes **vectors (nearly) normal to the face**, whose
        direction in the face is undefined. ``"raise"``: :class:`FieldShapeError`
        naming the faces. ``"warn"``: :class:`ZeroFieldWarning` and index 0 on those
        faces. Vectors that are steep but above the threshold are used as projected;
        their in-plane direction is sensitive to small changes, so a field that is
        close to normal to the surface can produce spurious +-1 faces.
    zero_rtol : float
        Relative threshold, default :data:`ZERO_RTOL`.

    Returns
    -------
    ndarray, int64 (m,)
        The index in each face: -1, 0 or +1.

    Raises
    ------
    FieldShapeError
        Wrong shape, non-finite values, or (``zero="raise"``) zero projected vectors.

    Examples
    --------
    >>> import fvf
    >>> from fvf.design.indices import face_singularities
    >>> mesh = fvf.disk(4, 6)
    >>> c = mesh.face_centroids[5]
    >>> face_singularities(mesh, (mesh.vertices - c) * [-1, 1, 0])[0].tolist()
    [5]
    """
    _check_zero_policy(zero)
    U = _as_vertex_field(mesh, U, "U")
    U = U / unit_scale(U)  # angles do not depend on the size: no overflow for 1e200
    B = mesh.face_bases  # (m, 2, 3)
    corner = U[mesh.faces]  # (m, 3, 3): [t, corner, xyz]
    z = np.einsum("tck,tk->tc", corner, B[:, 0]) + 1j * np.einsum("tck,tk->tc", corner, B[:, 1])
    scale = float(np.sqrt(np.einsum("ij,ij->i", U, U).max()))
    is_zero = _zero_mask(np.abs(z), scale, zero_rtol).any(axis=1)

    w = np.roll(z, -1, axis=1) * np.conj(z)  # phi_{i+1} - phi_i as a complex ratio
    turning = _wrap(np.arctan2(w.imag, w.real)).sum(axis=1)
    index = np.rint(turning / TWO_PI).astype(np.int64)

    if is_zero.any():
        faces = np.flatnonzero(is_zero)
        msg = (
            f"U projected onto faces {format_indices(faces)} is (numerically) zero at a "
            f"corner (zero or normal to the face; length <= {zero_rtol:g} times max |U|), "
            "so the index in those faces is undefined"
        )
        if zero == "raise":
            raise FieldShapeError(
                msg + ". Fix: perturb or re-sample the field, or pass zero='warn' to get "
                "index 0 there."
            )
        warnings.warn(msg + "; it was set to 0.", ZeroFieldWarning, stacklevel=2)
        index[faces] = 0
    return index


@takes_mesh
def face_singularities(
    mesh: TriMesh,
    U: npt.ArrayLike,
    *,
    zero: ZeroPolicy = "raise",
    zero_rtol: float = ZERO_RTOL,
) -> tuple[np.ndarray, np.ndarray]:
    """Faces inside which a per-vertex field has a non-zero index.

    Parameters
    ----------
    mesh : TriMesh
    U : array_like, float (n, 3) or (3n,)
        One ambient vector per vertex.
    zero, zero_rtol
        As in :func:`face_indices`.

    Returns
    -------
    face_ids : ndarray, int64 (s,)
        Sorted ids of the faces with non-zero index.
    indices : ndarray, int64 (s,)
        Their indices, each -1 or +1 (:func:`face_indices`).
    """
    index = face_indices(mesh, U, zero=zero, zero_rtol=zero_rtol)
    ids = np.flatnonzero(index).astype(np.int64)
    return ids, index[ids]


@takes_mesh
def singularity_positions(
    mesh: TriMesh, ids: npt.ArrayLike, kind: Literal["vertex", "face"] = "vertex"
) -> np.ndarray:
    """Positions of singularities, for plotting.

    Parameters
    ----------
    mesh : TriMesh
    ids : array_like of int, shape (s,)
        Vertex ids (from :func:`singularities`) or face ids (from
        :func:`face_singularities`).
    kind : {"vertex", "face"}
        ``"vertex"``: the vertex positions; ``"face"``: the face centroids.

    Returns
    -------
    ndarray, float64 (s, 3)

    Raises
    ------
    ParameterError
        Unknown ``kind``.
    FieldShapeError
        ``ids`` not a 1-D integer array, or out of range.
    """
    if kind == "vertex":
        P, what = mesh.vertices, "vertex"
    elif kind == "face":
        P, what = mesh.face_centroids, "face"
    else:
        raise ParameterError(f"kind must be 'vertex' or 'face'; got {kind!r}")
    ids = np.asarray(ids)
    if ids.size == 0:
        return np.empty((0, 3))
    if ids.ndim != 1 or not np.issubdtype(ids.dtype, np.integer):
        raise FieldShapeError(
            f"ids must be a 1-D integer array of {what} ids; got shape {ids.shape}, dtype "
            f"{ids.dtype}."
        )
    bad = (ids < 0) | (ids >= P.shape[0])
    if bad.any():
        raise FieldShapeError(
            f"{what} ids {format_indices(ids[bad])} are outside [0, {P.shape[0]})."
        )
    return np.array(P[ids], dtype=np.float64)
