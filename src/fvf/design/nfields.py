r"""N-direction fields: power representation, period jumps, cut graph and combing.

An **N-direction field** (N ≥ 1: 1 vector, 2 line, 4 cross, 6 …) assigns to each face
t a set of N tangent directions closed under rotation by 2π/N about the face normal. fvf
stores it as **one representative vector per face**, float64 (m, 3); the other
directions are its rotations by 2πj/N (:func:`all_directions`). Its length is a
magnitude (designed fields return lengths from the solve; normalise per face for unit
crosses).

Power representation (Knöppel, Crane, Pinkall & Schröder 2013, "Globally optimal
direction fields"): with ``z = mesh.to_complex(u)`` the representative in the face frame,

.. math::

    w_t = |z_t| \left(\frac{z_t}{|z_t|}\right)^{N},

which is the same for every representative of the set, so N-fields are ordinary complex
per-face values and their smoothness is the connection energy with the N-fold transport
r_st^N (:func:`fvf.connection_laplacian` with ``n``). :func:`to_power` and
:func:`from_power` convert both ways (``from_power`` returns the principal root
``|w| e^{i arg(w)/N}``).

Matching. Across an interior edge e with faces ``(s, t) = mesh.edge_faces[e]`` (s
traverses ``edges[e, 0] → edges[e, 1]``), let φ_e ∈ (−π, π] be the angle from the
representative of t, unfolded into s's plane about e (discrete Levi-Civita transport),
to the representative of s. The **period jump** is

.. math::

    p_e = \operatorname{rint}\!\Big(\frac{N \varphi_e}{2\pi}\Big) \bmod N \in \{0, …, N-1\},

the number of steps of 2π/N by which t's transported representative must be rotated
(counter-clockwise about s's normal) to be the direction of s's set closest to s's
representative. The principal matching (shortest rotation between the two sets) is
``φ_e − 2π p_e / N``. Around an interior vertex the jumps and the N-index satisfy
N·ind_v ≡ −Σ_e ±p_e (mod N), so only singular vertices carry non-trivial monodromy.

Combing. A field is *combed* on a set of faces when its representatives have p_e = 0 on
every edge between them. :func:`cut_graph` finds edges whose removal makes the surface a
topological disk through every singularity (a cut graph: the complement of a
breadth-first dual spanning tree, pruned of dangling branches that end at regular
interior vertices); :func:`comb` rotates the representatives so that p_e = 0 on every
uncut edge and returns the N combed fields. The rotation between the combed frames of
the two faces of a cut edge is then ``period_jumps(mesh, comb(...)[0], n)[e] · 2π/N``.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import numpy.typing as npt
import scipy.sparse as sp
from scipy.sparse import csgraph

from ..errors import CutGraphError, FieldShapeError, format_indices
from ..mesh.convert import takes_mesh
from ..mesh.geometry import cross_rows
from ..mesh.inputs import as_direction_count, as_face_field
from ..mesh.nfield import FROM_FIELD, FromField, NField, field_order
from ..mesh.trimesh import TriMesh
from ..numerics.summary import html_repr, short_repr
from .indices import ZERO_RTOL, as_connection_rotations, vertex_indices

__all__ = [
    "to_power",
    "from_power",
    "all_directions",
    "period_jumps",
    "CutGraph",
    "cut_graph",
    "comb",
]

TWO_PI = 2.0 * np.pi


# ---------------------------------------------------------------------------- representation
@takes_mesh
def to_power(mesh: TriMesh, u: npt.ArrayLike, n: int | FromField = FROM_FIELD) -> np.ndarray:
    """The power representation w = |z| (z/|z|)^N of an N-field, complex128 (m,).

    Parameters
    ----------
    mesh : TriMesh
    u : array_like, float (m, 3) or (3m,)
        One representative vector per face (normal parts are projected away, with a
        :class:`fvf.NonTangentFieldWarning` when they are not round-off).
    n : int, optional
        Symmetry order N ≥ 1; default: the ``n`` of an :class:`fvf.NField` ``u``
        (required for a bare array).

    Returns
    -------
    complex128 (m,)
        In the face frames (``mesh.face_bases``); the same for every rotation of u by
        2πj/N. Zero where u is zero. For n = 1 equal to ``mesh.to_complex(u)``.

    Raises
    ------
    DirectionCountError
        n not an integer ≥ 1.
    FieldShapeError, FieldValueError
        Wrong shape or non-finite values.
    """
    n = field_order(u, n, None, "u")
    u = as_face_field(mesh, u, "u")
    z = mesh.to_complex(u)
    if n == 1:
        return z
    r = np.abs(z)
    unit = z / np.where(r > 0, r, 1.0)
    return r * unit**n


@takes_mesh
def from_power(mesh: TriMesh, w: npt.ArrayLike, n: int) -> np.ndarray:
    """The principal representative |w| e^{i arg(w)/N} of a power field, float64 (m, 3).

    Parameters
    ----------
    mesh : TriMesh
    w : array_like, complex (m,)
        Power representation in the face frames (:func:`to_power`).
    n : int
        Symmetry order N ≥ 1.

    Returns
    -------
    NField, float64 (m, 3)
        Ambient tangent vectors of length |w| (zero where w is zero);
        ``to_power(mesh, from_power(mesh, w, n), n) == w`` up to round-off.

    Raises
    ------
    DirectionCountError
        n not an integer ≥ 1.
    FieldShapeError
        w not of shape (m,) or not finite.
    """
    n = as_direction_count(n)
    w = np.asarray(w)
    if w.shape != (mesh.n_faces,) or not np.issubdtype(w.dtype, np.number):
        raise FieldShapeError(
            f"w must be a complex array of shape ({mesh.n_faces},), one power coefficient "
            f"per face; got shape {w.shape}, dtype {w.dtype}."
        )
    w = w.astype(np.complex128)
    bad = np.flatnonzero(~np.isfinite(w))
    if bad.size:
        raise FieldShapeError(f"w has NaN or inf at faces {format_indices(bad)}.")
    z = w if n == 1 else np.abs(w) * np.exp(1j * np.angle(w) / n)
    return NField(mesh.from_complex(z), n)


@takes_mesh
def all_directions(mesh: TriMesh, u: npt.ArrayLike, n: int | FromField = FROM_FIELD) -> np.ndarray:
    """The N directions of each face: u rotated by 2πj/N, float64 (N, m, 3).

    ``n`` defaults to the ``n`` of an :class:`fvf.NField` ``u`` (required for a bare array).

    ``out[j, t]`` is ``cos(2πj/N) u_t + sin(2πj/N) N_t × u_t`` (counter-clockwise about
    the face normal); ``out[0]`` is the tangent part of u.
    """
    n = field_order(u, n, None, "u")
    u = as_face_field(mesh, u, "u")
    Ju = cross_rows(mesh.face_normals, u)
    ang = TWO_PI * np.arange(n) / n
    return np.cos(ang)[:, None, None] * u[None] + np.sin(ang)[:, None, None] * Ju[None]


# ---------------------------------------------------------------------------- matching
def edge_angles(
    mesh: TriMesh, u: np.ndarray, rotations: npt.ArrayLike | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Interior edges and φ_e: the angle from t's unfolded representative to s's, (k,),
    in (−π, π]; with ``rotations`` (E,) the transport of edge e is turned by x_e and
    φ_e − x_e (wrapped) is returned (see :func:`period_jumps`)."""
    X, N, E, EF = mesh.vertices, mesh.face_normals, mesh.edges, mesh.edge_faces
    length = np.linalg.norm(u, axis=1)
    u = u / np.where(length > 0, length, 1.0)[:, None]  # huge fields: no overflow below
    interior = np.flatnonzero((EF >= 0).all(axis=1))
    s, t = EF[interior, 0], EF[interior, 1]
    ev = X[E[interior, 1]] - X[E[interior, 0]]

    def rel(f: np.ndarray) -> np.ndarray:  # the direction of u_f measured from e, ccw
        return np.einsum("ij,ij->i", ev, u[f]) + 1j * np.einsum(
            "ij,ij->i", cross_rows(N[f], ev), u[f]
        )

    z = rel(s) * np.conj(rel(t))
    if rotations is not None:
        z = z * np.exp(-1j * as_connection_rotations(mesh, rotations)[interior])
    return interior, np.arctan2(z.imag, z.real)


def check_nonzero(mesh: TriMesh, u: np.ndarray, what: str) -> None:
    """Raise :class:`fvf.FieldShapeError` naming the faces where u (m, 3) is (numerically)
    zero (``what``: the quantity left undefined there)."""
    length = np.linalg.norm(u, axis=1)
    scale = float(length.max(initial=0.0))
    zero = np.flatnonzero(length <= ZERO_RTOL * scale) if scale > 0 else np.arange(u.shape[0])
    if zero.size:
        raise FieldShapeError(
            f"u is (numerically) zero at faces {format_indices(zero)}, so its directions "
            f"there, and {what}, are undefined. Fix: perturb or re-design the field there "
            "(e.g. fvf.design_field with constraints on those faces)."
        )


@takes_mesh
def period_jumps(
    mesh: TriMesh,
    u: npt.ArrayLike,
    n: int | FromField = FROM_FIELD,
    *,
    connection_rotations: npt.ArrayLike | None = None,
) -> np.ndarray:
    """The period jump p_e ∈ {0, …, N−1} of an N-field across every edge, int64 (E,).

    Parameters
    ----------
    mesh : TriMesh
    u : array_like, float (m, 3)
        One representative vector per face.
    n : int, optional
        Symmetry order N ≥ 1; default: the ``n`` of an :class:`fvf.NField` ``u``
        (required for a bare array).
    connection_rotations : float (E,), optional
        Angles x_e added to the Levi-Civita transport across each edge (``mesh.edges``
        order; :func:`fvf.design.holonomy.holonomy_rotations`): the field is measured
        against that connection, whose holonomy around v is K_v − (Gᵀx)_v. Default: none.

    Returns
    -------
    int64 (E,), indexed like ``mesh.edges``
        On interior edges, the p_e of the module docstring: s's representative is closest
        to t's representative transported into s and rotated by p_e·2π/N
        (``(s, t) = mesh.edge_faces[e]``). Boundary edges get 0. For n = 1 every jump is 0.

    Raises
    ------
    FieldShapeError
        Wrong shape, non-finite values or a zero vector on some face (its directions are
        undefined), naming the faces.
    DirectionCountError
        n not an integer ≥ 1.
    """
    n = field_order(u, n, None, "u")
    u = as_face_field(mesh, u, "u")
    check_nonzero(mesh, u, "the period jumps of its edges")
    out = np.zeros(mesh.n_edges, dtype=np.int64)
    interior, phi = edge_angles(mesh, u, connection_rotations)
    out[interior] = np.mod(np.rint(n * phi / TWO_PI).astype(np.int64), n)
    return out


# ---------------------------------------------------------------------------- cut graph
@dataclasses.dataclass(frozen=True)
class CutGraph:
    """A cut graph of a mesh for an N-field (:func:`cut_graph`).

    Attributes
    ----------
    mask : bool (E,)
        True on the cut edges, indexed like ``mesh.edges``; never on boundary edges.
    edges : int64 (k, 2)
        The cut edges as vertex pairs ``mesh.edges[mask]`` (i < j).
    singular_vertices : int64 (s,)
        The vertices with a non-zero N-index (all lie on the cut or on the boundary
        fan of a cut).
    indices : float64 (s,)
        Their indices (multiples of 1/N).
    """

    __repr__ = short_repr  # arrays by dtype and shape
    _repr_html_ = html_repr  # a table in Jupyter

    mask: np.ndarray
    edges: np.ndarray
    singular_vertices: np.ndarray
    indices: np.ndarray


def _bfs_forest(mesh: TriMesh, edge_ids: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Breadth-first spanning forest of the faces joined across the given interior edges.

    Returns (parent face or -1, edge id to the parent or -1), each int64 (m,). One search
    from a virtual root joined to the lowest face of every component.
    """
    m = mesh.n_faces
    EF = mesh.edge_faces[edge_ids]
    rows = np.concatenate([EF[:, 0], EF[:, 1]])
    cols = np.concatenate([EF[:, 1], EF[:, 0]])
    G = sp.csr_array((np.ones(rows.size), (rows, cols)), shape=(m, m))
    _, label = csgraph.connected_components(G, directed=False)
    roots = np.full(label.max() + 1, m, dtype=np.int64)
    np.minimum.at(roots, label, np.arange(m))
    r2 = np.concatenate([rows, np.full(roots.size, m)])
    c2 = np.concatenate([cols, roots])
    H = sp.csr_array((np.ones(r2.size), (r2, c2)), shape=(m + 1, m + 1))
    _, pred = csgraph.breadth_first_order(H, m, directed=True)
    parent = np.asarray(pred[:m], dtype=np.int64)
    parent[parent == m] = -1
    child = np.flatnonzero(parent >= 0)
    # the edge of each tree pair: the allowed edge of the child shared with its parent
    allowed = np.zeros(mesh.n_edges, dtype=bool)
    allowed[edge_ids] = True
    fe = mesh.face_edges[child]
    match = (mesh.face_adjacency[child] == parent[child][:, None]) & allowed[fe]
    via = np.full(m, -1, dtype=np.int64)
    via[child] = fe[np.arange(child.size), np.argmax(match, axis=1)]
    return parent, via


def _prune(E: np.ndarray, active: np.ndarray, keep: np.ndarray, n_vertices: int) -> np.ndarray:
    """Repeatedly remove edges with an endpoint of degree 1 that is not a ``keep`` vertex."""
    while active.size:
        deg = np.bincount(E[active].ravel(), minlength=n_vertices)
        leaf = (deg == 1) & ~keep
        drop = leaf[E[active, 0]] | leaf[E[active, 1]]
        if not drop.any():
            break
        active = active[~drop]
    return active


@takes_mesh
def cut_graph(
    mesh: TriMesh,
    u: npt.ArrayLike,
    n: int | FromField = FROM_FIELD,
    *,
    connection_rotations: npt.ArrayLike | None = None,
) -> CutGraph:
    """A cut graph through the singularities that makes an N-field combable.

    Parameters
    ----------
    mesh : TriMesh
    u : array_like, float (m, 3)
        One representative vector per face, non-zero on every face.
    n : int, optional
        Symmetry order N ≥ 1; default: the ``n`` of an :class:`fvf.NField` ``u``
        (required for a bare array).
    connection_rotations : float (E,), optional
        As in :func:`period_jumps`: the singularities are measured against that connection.

    Returns
    -------
    CutGraph
        ``mask`` (bool over ``mesh.edges``) and ``edges`` ((k, 2) vertex pairs) of the cut.

    Notes
    -----
    Construction (tree–cotree; Erickson & Whittlesey 2005, used for combing by e.g.
    Bommes et al. 2009 and libigl's ``cut_mesh_from_singularities``):

    1. a breadth-first spanning forest of the dual graph (faces joined across interior
       edges);
    2. the candidate cut: every interior edge not crossed by the forest — on a closed
       surface of genus g this is a spanning tree of the vertices plus 2g edges;
    3. pruning: edges with an endpoint of degree 1 that is neither singular (N-index ≠ 0)
       nor on the boundary are removed, until none is left.

    Cutting along the result leaves each connected component a topological disk (on a
    closed component: 2g loops through one vertex plus the paths to every singularity;
    with boundary: paths from every singularity and between boundary loops to the
    boundary). A removed edge ends at a regular vertex whose other edges are uncut, so the
    monodromy relation N·ind ≡ −Σ ±p_e (mod N) forces its jump to 0 after combing along
    the forest: the field is combable on the cut surface (:func:`comb`). Cost: the
    pruning runs one vectorised pass per layer of dangling branches.

    Raises
    ------
    FieldShapeError
        Zero vectors, wrong shape or non-finite values.
    DirectionCountError
        n not an integer ≥ 1.
    """
    n = field_order(u, n, None, "u")
    u = as_face_field(mesh, u, "u")
    check_nonzero(mesh, u, "the cut graph through its singularities")
    E, EF = mesh.edges, mesh.edge_faces
    interior = np.flatnonzero((EF >= 0).all(axis=1))
    _, via = _bfs_forest(mesh, interior)
    in_tree = np.zeros(mesh.n_edges, dtype=bool)
    in_tree[via[via >= 0]] = True
    candidate = interior[~in_tree[interior]]
    index = np.asarray(
        vertex_indices(mesh, u, n=n, connection_rotations=connection_rotations), dtype=float
    )
    keep = index != 0
    keep[mesh.boundary_vertices] = True
    cut = _prune(E, candidate, keep, mesh.n_vertices)
    mask = np.zeros(mesh.n_edges, dtype=bool)
    mask[cut] = True
    sing = np.flatnonzero(index).astype(np.int64)
    return CutGraph(mask, E[mask].copy(), sing, index[sing])


# ---------------------------------------------------------------------------- combing
def _as_cut_mask(mesh: TriMesh, cut: CutGraph | npt.ArrayLike) -> np.ndarray:
    """A user cut (CutGraph, bool (E,) or (k, 2) vertex pairs) as a bool mask over edges."""
    if isinstance(cut, CutGraph):
        cut = cut.mask
    c = np.asarray(cut)
    E = mesh.n_edges
    if c.dtype == bool:
        if c.shape != (E,):
            raise CutGraphError(
                f"a boolean cut must have shape ({E},), one flag per mesh.edges row; got {c.shape}."
            )
        mask = c.copy()
    elif np.issubdtype(c.dtype, np.integer) and c.ndim == 2 and c.shape[1] == 2:
        ids = mesh.edge_ids(c)
        bad = np.flatnonzero(ids < 0)
        if bad.size:
            raise CutGraphError(
                f"cut rows {format_indices(bad)} are not edges of the mesh (e.g. "
                f"{c[bad[0]].tolist()}). Fix: give vertex pairs from mesh.edges."
            )
        mask = np.zeros(E, dtype=bool)
        mask[ids] = True
    else:
        raise CutGraphError(
            f"cut must be a CutGraph, a bool array ({E},) or an int array (k, 2) of vertex "
            f"pairs; got shape {c.shape}, dtype {c.dtype}."
        )
    return mask


def _tree_sums(parent: np.ndarray, delta: np.ndarray) -> np.ndarray:
    """Sum of ``delta`` along the path from each node to its root (pointer doubling)."""
    acc = delta.copy()
    ptr = parent.copy()
    while True:
        live = np.flatnonzero(ptr >= 0)
        if not live.size:
            return acc
        nxt = ptr[live]
        acc[live] += acc[nxt]
        ptr[live] = ptr[nxt]


@takes_mesh
def comb(
    mesh: TriMesh,
    u: npt.ArrayLike,
    n: int | FromField = FROM_FIELD,
    cut: CutGraph | npt.ArrayLike | None = None,
    *,
    connection_rotations: npt.ArrayLike | None = None,
) -> np.ndarray:
    """The N combed fields of an N-field: smooth (zero period jump) on every uncut edge.

    Parameters
    ----------
    mesh : TriMesh
    u : array_like, float (m, 3)
        One representative vector per face, non-zero on every face.
    n : int, optional
        Symmetry order N ≥ 1; default: the ``n`` of an :class:`fvf.NField` ``u``
        (required for a bare array).
    cut : CutGraph, bool (E,) or int (k, 2), optional
        The cut: a :func:`cut_graph` result, a mask over ``mesh.edges`` or vertex pairs.
        Default: ``cut_graph(mesh, u, n)``. Boundary edges are never crossed.
    connection_rotations : float (E,), optional
        As in :func:`period_jumps`: the combed field has zero period jump relative to
        that connection on every uncut edge.

    Returns
    -------
    float64 (N, m, 3)
        ``out[j]`` is the combed representative rotated by 2πj/N (``out[0]`` the combed
        field itself; the same vector set as u on every face, same lengths). On every
        uncut interior edge ``period_jumps(mesh, out[j], n)`` is 0; on a cut edge it is the
        rotation k·2π/N between the combed frames of its two faces (the matching a
        seamless parameterization needs).

    Raises
    ------
    CutGraphError
        Malformed cut, or a cut that leaves a loop with non-trivial monodromy uncut (it
        does not pass through every singularity or does not cut the surface into disks),
        naming the uncut edges that keep a jump.
    FieldShapeError
        Zero vectors, wrong shape or non-finite values.
    DirectionCountError
        n not an integer ≥ 1.

    Notes
    -----
    Breadth-first search over the faces joined by uncut interior edges (one tree per
    component of the cut surface); each face's rotation is the sum of the jumps along its
    tree path to the root, accumulated by pointer doubling (O(m log depth), vectorised).
    """
    n = field_order(u, n, None, "u")
    u = as_face_field(mesh, u, "u")
    check_nonzero(mesh, u, "its combing")
    rot = connection_rotations
    mask = (
        cut_graph(mesh, u, n, connection_rotations=rot).mask
        if cut is None
        else _as_cut_mask(mesh, cut)
    )
    EF = mesh.edge_faces
    interior = np.flatnonzero((EF >= 0).all(axis=1))
    uncut = interior[~mask[interior]]
    jumps = period_jumps(mesh, u, n, connection_rotations=rot)
    parent, via = _bfs_forest(mesh, uncut)
    # rotation k_f (steps of 2π/N): jump' = p_e + k_s − k_t must vanish on tree edges
    child = np.flatnonzero(parent >= 0)
    e = via[child]
    is_t = EF[e, 1] == child
    delta = np.zeros(mesh.n_faces, dtype=np.int64)
    delta[child] = np.where(is_t, jumps[e], -jumps[e])
    k = np.mod(_tree_sums(parent, delta), n)
    ang = TWO_PI * k / n
    Ju = cross_rows(mesh.face_normals, u)
    combed = np.cos(ang)[:, None] * u + np.sin(ang)[:, None] * Ju
    new = period_jumps(mesh, combed, n, connection_rotations=rot)
    bad = uncut[new[uncut] != 0]
    if bad.size:
        raise CutGraphError(
            f"the cut leaves edges {format_indices(bad)} uncut across which the field cannot "
            "be combed (a loop of uncut edges around a singularity, or a handle, that the "
            "cut does not open). Fix: use fvf.cut_graph(mesh, u, n), or add edges through "
            "every singular vertex and around every handle."
        )
    return all_directions(mesh, combed, n)
