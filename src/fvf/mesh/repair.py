"""Explicit, opt-in repairs of raw mesh arrays; each returns the index maps it applied.

:class:`fvf.TriMesh` never repairs anything: broken input raises a typed error from
:mod:`fvf.errors` that names the function of this module to call. Every repair here takes
raw arrays (vertices ``(n, 3)`` float, faces ``(m, 3)`` int: a TriMesh cannot even be built
from broken input), never modifies them, and returns a :class:`RepairResult` with the new
arrays, the maps between old and new vertices and faces, and a log line saying what changed.
A mesh that needs no repair comes back equal, with identity maps and an empty log.

``docs/repair.md`` has a recipe for a messy scan; :func:`repair_mesh` applies several steps in
order and composes their maps.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components

from ..errors import (
    NonFiniteError,
    NonManifoldError,
    NonOrientableError,
    format_indices,
)
from . import halfedges
from .defects import (
    duplicate_faces,
    non_orientable_message,
    nonmanifold_message,
    raw_arrays,
    repeats_vertex,
    zero_area_faces,
)
from .inputs import unit_scale
from .spikes import SPIKE_RATIO, flattened_spikes
from .t_junctions import t_junction_splits
from .trimesh import DEGENERATE_AREA_RTOL

__all__ = [
    "RepairResult",
    "remove_unreferenced_vertices",
    "remove_duplicate_vertices",
    "remove_degenerate_faces",
    "split_t_junctions",
    "remove_duplicate_faces",
    "orient_faces",
    "split_nonmanifold_vertices",
    "split_nonmanifold_edges",
    "flatten_spikes",
    "repair_mesh",
    "REPAIR_STEPS",
    "DEFAULT_REPAIR_STEPS",
]


# ---------------------------------------------------------------------------- result type
@dataclass(frozen=True, eq=False)
class RepairResult:
    """The repaired arrays and the index maps that lead from the old mesh to the new one.

    ``n``/``m`` are the old vertex/face counts, ``n'``/``m'`` the new ones.

    Attributes
    ----------
    vertices : float64 (n', 3)
        New vertex positions; ``vertices[i] == old_vertices[vertex_origin[i]]``, except
        the vertices :func:`flatten_spikes` moved (its log names them).
    faces : int64 (m', 3)
        New faces, indices into ``vertices``.
    vertex_origin : int64 (n',)
        The old vertex each new vertex is, or is a copy of (new -> old). After a split,
        several new vertices share one origin. ``f_old[vertex_origin]`` carries a per-vertex
        array to the new mesh (:meth:`vertex_values`).
    vertex_map : int64 (n,)
        The new index of each old vertex (old -> new), ``-1`` if it was removed. Merged
        vertices map to the one vertex they became; a split vertex maps to the copy that
        kept its index (the others are the new vertices whose origin is it).
    face_origin : int64 (m',)
        The old face each new face is (new -> old). ``g_old[face_origin]`` carries a
        per-face array (:meth:`face_values`).
    face_map : int64 (m,)
        The new index of each old face, ``-1`` if it was removed.
    flipped : bool (m',)
        True where the new face lists its old face's vertices in the opposite order
        (corners 1 and 2 swapped), so its normal and the rotation J changed sign.
    log : tuple of str
        One line per step that changed something, naming the indices involved.
    mesh : TriMesh
        The repaired mesh (property, built on first use).

    Notes
    -----
    For compatibility with the tuple the first repair returned, iterating over a result
    and indexing it behave like the tuple ``(vertices, faces, vertex_origin)``: ``V, F, kept =
    remove_unreferenced_vertices(V, F)`` still works.
    """

    vertices: np.ndarray
    faces: np.ndarray
    vertex_origin: np.ndarray
    vertex_map: np.ndarray
    face_origin: np.ndarray
    face_map: np.ndarray
    flipped: np.ndarray
    log: tuple[str, ...] = ()

    def __iter__(self):
        return iter((self.vertices, self.faces, self.vertex_origin))

    def __len__(self) -> int:
        return 3

    def __getitem__(self, index):
        return (self.vertices, self.faces, self.vertex_origin)[index]

    def __repr__(self) -> str:
        return (
            f"RepairResult({self.vertex_map.size} -> {self.vertices.shape[0]} vertices, "
            f"{self.face_map.size} -> {self.faces.shape[0]} faces, "
            f"{int(self.flipped.sum())} flipped, log={list(self.log)})"
        )

    def _repr_html_(self) -> str:
        """A table for Jupyter: vertices and faces before and after, flips, the log."""
        from ..numerics.summary import html_table

        return html_table(
            "RepairResult",
            [
                ("vertices", f"{self.vertex_map.size} → {self.vertices.shape[0]}"),
                ("faces", f"{self.face_map.size} → {self.faces.shape[0]}"),
                ("flipped faces", int(self.flipped.sum())),
                *[("step", line) for line in self.log],
            ],
        )

    @property
    def mesh(self):
        """The repaired mesh as a :class:`fvf.TriMesh` (built on first use, then kept).

        Raises
        ------
        fvf.errors.MeshError
            The repair steps that ran did not fix everything (the message names what is
            left; :func:`repair_mesh` with its default steps fixes what it can).
        """
        cached = self.__dict__.get("_mesh")
        if cached is None:
            from .trimesh import TriMesh

            cached = TriMesh(self.vertices, self.faces)
            object.__setattr__(self, "_mesh", cached)
        return cached

    @property
    def changed(self) -> bool:
        """True when the repair changed the mesh (the log is then non-empty)."""
        return bool(self.log)

    def vertex_values(self, values: npt.ArrayLike) -> np.ndarray:
        """A per-vertex array of the old mesh, (n, ...), carried to the new one: (n', ...)."""
        return np.asarray(values)[self.vertex_origin]

    def face_values(self, values: npt.ArrayLike) -> np.ndarray:
        """A per-face array of the old mesh, (m, ...), carried to the new one: (m', ...).

        Ambient vectors (tangent fields as (m, 3) arrays) carry over unchanged; a quantity
        that depends on the face orientation (normals, a field given by its rotation J u)
        changes sign on the :attr:`flipped` faces.
        """
        return np.asarray(values)[self.face_origin]

    def then(self, later: RepairResult) -> RepairResult:
        """The composition: this repair followed by ``later`` (applied to this output)."""
        return RepairResult(
            vertices=later.vertices,
            faces=later.faces,
            vertex_origin=self.vertex_origin[later.vertex_origin],
            vertex_map=_follow(self.vertex_map, later.vertex_map),
            face_origin=self.face_origin[later.face_origin],
            face_map=_follow(self.face_map, later.face_map),
            flipped=self.flipped[later.face_origin] ^ later.flipped,
            log=self.log + later.log,
        )


def _follow(first: np.ndarray, second: np.ndarray) -> np.ndarray:
    """Compose old -> new maps with -1 for removed entries."""
    out = np.full(first.shape, -1, dtype=np.int64)
    kept = first >= 0
    out[kept] = second[first[kept]]
    return out


def _inverse(origin: np.ndarray, size: int) -> np.ndarray:
    """old -> new map (size,) from a new -> old map, -1 where nothing maps; an old index
    with several new ones (a face split in two) maps to the first."""
    out = np.full(size, -1, dtype=np.int64)
    out[origin[::-1]] = np.arange(origin.size)[::-1]
    return out


def _result(
    V: np.ndarray,
    F: np.ndarray,
    n_old: int,
    m_old: int,
    vertex_origin: np.ndarray | None = None,
    face_origin: np.ndarray | None = None,
    vertex_map: np.ndarray | None = None,
    flipped: np.ndarray | None = None,
    log: str = "",
) -> RepairResult:
    if vertex_origin is None:
        vertex_origin = np.arange(n_old)
    if face_origin is None:
        face_origin = np.arange(m_old)
    if vertex_map is None:
        vertex_map = _inverse(vertex_origin, n_old)
    if flipped is None:
        flipped = np.zeros(F.shape[0], dtype=bool)
    return RepairResult(
        vertices=V,
        faces=F,
        vertex_origin=vertex_origin.astype(np.int64, copy=False),
        vertex_map=vertex_map.astype(np.int64, copy=False),
        face_origin=face_origin.astype(np.int64, copy=False),
        face_map=_inverse(face_origin, m_old),
        flipped=flipped,
        log=(log,) if log else (),
    )


# ---------------------------------------------------------------------------- repairs
def remove_unreferenced_vertices(vertices: npt.ArrayLike, faces: npt.ArrayLike) -> RepairResult:
    """Drop vertices that no face uses, keeping the order of the others.

    Parameters
    ----------
    vertices : array_like (n, 3)
    faces : array_like of int (m, 3)

    Returns
    -------
    RepairResult
        ``vertex_origin`` (n',) is the old index of each kept vertex (``f_old[vertex_origin]``
        restricts a function to the new mesh); ``vertex_map`` (n,) is ``-1`` for the dropped
        vertices. Faces are only re-indexed. Unpacks as ``V, F, kept``.
    """
    V, F = raw_arrays(vertices, faces)
    n = V.shape[0]
    used = np.zeros(n, dtype=bool)
    used[F.ravel()] = True
    kept = np.flatnonzero(used)
    new_index = _inverse(kept, n)
    log = ""
    if kept.size < n:
        log = (
            f"remove_unreferenced_vertices: removed vertices "
            f"{format_indices(np.flatnonzero(~used))}, which belong to no face"
        )
    return _result(V[kept], new_index[F], n, F.shape[0], vertex_origin=kept, log=log)


def remove_duplicate_vertices(
    vertices: npt.ArrayLike, faces: npt.ArrayLike, tol: float = 0.0
) -> RepairResult:
    """Merge coincident vertices (welding an unwelded "triangle soup" or a cut seam).

    Parameters
    ----------
    vertices : array_like (n, 3)
    faces : array_like of int (m, 3)
    tol : float
        Merge distance relative to the bounding-box diagonal. ``0`` merges exactly equal
        coordinates only (``-0.0 == 0.0``). With ``tol > 0`` vertices within
        ``tol * diagonal`` are merged, transitively: a chain of close vertices becomes one
        vertex even if its ends are farther apart.

    Returns
    -------
    RepairResult
        Each group of merged vertices becomes its lowest-index member, at that member's
        position (coordinates are never averaged, so an exact merge loses nothing), and the
        kept vertices stay in their old order. ``vertex_map`` (n,) sends every old vertex to
        the vertex it was merged into (never ``-1``); ``vertex_origin`` (n',) is the
        representative's old index. Faces are re-indexed, never dropped: a face that now
        repeats a vertex is named in the log; remove it with :func:`remove_degenerate_faces`.

    Raises
    ------
    NonFiniteError
        ``tol > 0`` and some coordinates are NaN or inf.
    """
    V, F = raw_arrays(vertices, faces)
    n = V.shape[0]
    if tol < 0:
        raise ValueError(f"tol must be >= 0, got {tol}")
    radius = 0.0
    if tol > 0 and n:
        finite = np.isfinite(V).all(axis=1)
        if not finite.all():
            raise NonFiniteError(
                f"vertices {format_indices(np.flatnonzero(~finite))} have NaN or inf "
                "coordinates, so distances to them are undefined. Fix: remove them (and "
                "their faces) first, or merge with tol=0."
            )
        # distances in units of the largest coordinate: a vertex at 1e308 would overflow
        # the bounding box diagonal and the KD-tree's squared distances
        scale = float(np.abs(V).max())
        unit = V / scale if scale > 0 else V
        radius = tol * float(np.linalg.norm(np.ptp(unit, axis=0)))
    if radius > 0:
        from scipy.spatial import cKDTree

        pairs = cKDTree(unit).query_pairs(radius, output_type="ndarray")
        g = sp.coo_array((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n))
        _, label = connected_components(g, directed=False)
        rep_of_label = np.full(label.max(initial=-1) + 1, n, dtype=np.int64)
        np.minimum.at(rep_of_label, label, np.arange(n))
        rep = rep_of_label[label]
    else:
        X = V + 0.0  # -0.0 -> 0.0
        order = np.lexsort((np.arange(n), X[:, 2], X[:, 1], X[:, 0]))
        Xs = X[order]
        new = np.ones(n, dtype=bool)
        new[1:] = (Xs[1:] != Xs[:-1]).any(axis=1)
        rep = np.empty(n, dtype=np.int64)
        rep[order] = order[np.flatnonzero(new)][np.cumsum(new) - 1]
    kept = np.flatnonzero(rep == np.arange(n))
    vertex_map = _inverse(kept, n)[rep]
    F2 = vertex_map[F]
    log = ""
    merged = np.flatnonzero(rep != np.arange(n))
    if merged.size:
        log = (
            f"remove_duplicate_vertices: merged vertices {format_indices(merged)} into "
            f"coincident lower-index vertices ({n} -> {kept.size} vertices)"
        )
        rep_faces = np.flatnonzero(repeats_vertex(F2) & ~repeats_vertex(F))
        if rep_faces.size:
            log += (
                f"; faces {format_indices(rep_faces)} now repeat a vertex: call "
                "fvf.remove_degenerate_faces(V, F)"
            )
    return _result(V[kept], F2, n, F.shape[0], vertex_origin=kept, vertex_map=vertex_map, log=log)


#: Passes of :func:`split_t_junctions` at most (a pass splits or flips each face once; a
#: pocket of zero-area faces in a row along a crease takes one pass per face in the row).
T_JUNCTION_PASSES = 32


def split_t_junctions(
    vertices: npt.ArrayLike, faces: npt.ArrayLike, area_rtol: float = DEGENERATE_AREA_RTOL
) -> RepairResult:
    """Remove zero-area faces whose apex lies on their longest edge and split the face
    across that edge at the apex, so that no slit is left; flip the long edge shared by two
    zero-area faces first (:mod:`fvf.mesh.t_junctions`).

    Parameters
    ----------
    vertices : array_like (n, 3)
    faces : array_like of int (m, 3)
    area_rtol : float
        Zero area as in :func:`remove_degenerate_faces`.

    Returns
    -------
    RepairResult
        Vertices unchanged; ``face_map`` is ``-1`` for the removed faces, and both halves
        of a split face have it as ``face_origin``; a flipped pair keeps its two face
        indices. Zero-area faces it cannot resolve (on the boundary, on a non-manifold
        edge) are left for :func:`remove_degenerate_faces`.
    """
    V, F = raw_arrays(vertices, faces)
    total = _result(V.copy(), F.copy(), V.shape[0], F.shape[0])
    for _ in range(T_JUNCTION_PASSES):
        G, origin, removed, split, flipped = t_junction_splits(V, total.faces, area_rtol)
        if removed.size == 0 and flipped.size == 0:
            break
        done = []
        if removed.size:
            done.append(
                f"removed zero-area faces {format_indices(removed)} and split the faces "
                f"across their long edges {format_indices(split)} at their apexes"
            )
        if flipped.size:
            done.append(
                "flipped the long edge shared by each pair of zero-area faces in "
                f"{format_indices(flipped.ravel())}"
            )
        log = "split_t_junctions: " + "; ".join(done)
        m = total.faces.shape[0]
        total = total.then(_result(V.copy(), G, V.shape[0], m, face_origin=origin, log=log))
    return total


def remove_degenerate_faces(
    vertices: npt.ArrayLike, faces: npt.ArrayLike, area_rtol: float = DEGENERATE_AREA_RTOL
) -> RepairResult:
    """Drop faces that repeat a vertex or have (numerically) zero area.

    Parameters
    ----------
    vertices : array_like (n, 3)
    faces : array_like of int (m, 3)
    area_rtol : float
        A face is degenerate when its area is at most ``area_rtol`` times its longest edge
        squared; the default is the threshold :class:`fvf.TriMesh` rejects.

    Returns
    -------
    RepairResult
        Vertices unchanged (identity vertex maps); ``face_origin`` (m',) lists the kept old
        faces in order, ``face_map`` (m,) is ``-1`` for the dropped ones.

    Notes
    -----
    Dropping a zero-area face whose three vertices are distinct (a sliver whose apex lies on
    the opposite edge, a "T-junction") leaves a crack there: the mesh gets a boundary, or
    a vertex joining two fans (then call :func:`split_nonmanifold_vertices`). Vertices used
    only by dropped faces become unreferenced: the log says so; call
    :func:`remove_unreferenced_vertices`.
    """
    V, F = raw_arrays(vertices, faces)
    repeats = repeats_vertex(F)
    flat = ~repeats & zero_area_faces(V, F, area_rtol)
    keep = ~(repeats | flat)
    kept = np.flatnonzero(keep)
    log = ""
    if kept.size < F.shape[0]:
        parts = []
        if repeats.any():
            parts.append(f"faces {format_indices(np.flatnonzero(repeats))} that repeat a vertex")
        if flat.any():
            parts.append(f"zero-area faces {format_indices(np.flatnonzero(flat))}")
        log = "remove_degenerate_faces: removed " + " and ".join(parts)
        used = np.zeros(V.shape[0], dtype=bool)
        used[F[kept].ravel()] = True
        was = np.zeros(V.shape[0], dtype=bool)
        was[F.ravel()] = True
        orphan = np.flatnonzero(was & ~used)
        if orphan.size:
            log += (
                f"; vertices {format_indices(orphan)} are now unreferenced: call "
                "fvf.remove_unreferenced_vertices(V, F)"
            )
    return _result(V.copy(), F[kept], V.shape[0], F.shape[0], face_origin=kept, log=log)


def remove_duplicate_faces(vertices: npt.ArrayLike, faces: npt.ArrayLike) -> RepairResult:
    """Drop faces with the same vertex set as an earlier face, flipped copies included.

    Parameters
    ----------
    vertices : array_like (n, 3)
    faces : array_like of int (m, 3)

    Returns
    -------
    RepairResult
        Vertices unchanged; the first face (lowest index) of each vertex set is kept, in its
        own vertex order. ``face_origin`` (m',) lists the kept faces, ``face_map`` (m,) is
        ``-1`` for the dropped copies.

    Notes
    -----
    A flipped duplicate (same three vertices, opposite order) is dropped too: two faces on
    the same triangle with opposite normals enclose no volume and make all three edges
    non-manifold or the orientation inconsistent; which normal is right is then decided by
    :func:`orient_faces` from the neighbours, not by which copy came first.
    """
    V, F = raw_arrays(vertices, faces)
    duplicate, reversed_ = duplicate_faces(F)
    kept = np.flatnonzero(~duplicate)
    log = ""
    if duplicate.any():
        log = (
            f"remove_duplicate_faces: removed faces {format_indices(np.flatnonzero(duplicate))}"
            f" that repeat an earlier face's vertices ({int(reversed_.sum())} of them in the "
            "opposite order)"
        )
    return _result(V.copy(), F[kept], V.shape[0], F.shape[0], face_origin=kept, log=log)


def orient_faces(
    vertices: npt.ArrayLike, faces: npt.ArrayLike, outward: bool = True
) -> RepairResult:
    """Orient the faces of each connected component consistently.

    Two faces sharing an edge must traverse it in opposite directions (chapter §3.1: the
    normals, the rotation J of eq. (27) and every operator built on it depend on it).

    Parameters
    ----------
    vertices : array_like (n, 3)
    faces : array_like of int (m, 3)
        Each edge in at most two faces (faces meeting only at a vertex are fine).
    outward : bool
        Orient each closed component so that its signed volume is positive (normals point
        out). Components with boundary, and all components when False, keep the orientation
        of most of their faces (ties: the orientation of their lowest-index face).

    Returns
    -------
    RepairResult
        Vertices and face order unchanged; ``flipped`` (m,) marks the faces whose corners 1
        and 2 were swapped (``faces[t] = old[t, [0, 2, 1]]``).

    Raises
    ------
    NonManifoldError
        An edge is in more than two faces (orientation across it is undefined).
    NonOrientableError
        A component is non-orientable (a Möbius strip, a Klein bottle); the message names
        its faces (an :class:`OrientationError`).

    Notes
    -----
    Components are faces joined across edges. Consistency is a parity problem: for each
    interior edge the two faces need equal flips if they traverse it in opposite directions
    and different flips otherwise. It is solved without a traversal loop: on the double
    cover with nodes (face, kept) and (face, flipped) each interior edge joins the nodes of
    equal parity, and one ``connected_components`` call splits every orientable component
    into its two sheets. A component is non-orientable exactly when a face's two nodes land
    on one sheet.
    """
    V, F = raw_arrays(vertices, faces)
    n, m = V.shape[0], F.shape[0]
    runs = halfedges.sort_halfedges(F, n)
    bad = np.flatnonzero(runs.counts > 2)
    if bad.size:
        raise NonManifoldError("cannot orient: " + nonmanifold_message(F, runs, bad))
    sheet, comp = halfedges.orientation_sheets(runs, m)
    n_comp = int(np.count_nonzero(np.bincount(comp)))
    bad_faces = np.flatnonzero(sheet[:m] == sheet[m:])
    if bad_faces.size:
        raise NonOrientableError(non_orientable_message(bad_faces, comp))
    n_labels = 2 * m
    root = np.full(n_labels, m, dtype=np.int64)
    np.minimum.at(root, comp, np.arange(m))
    flip = sheet[m:] == sheet[root[comp]]  # on the sheet where the root face is unflipped
    size = np.bincount(comp, minlength=n_labels)
    invert = 2 * np.bincount(comp, weights=flip, minlength=n_labels) > size
    if outward and m:
        open_face = np.zeros(m, dtype=bool)
        open_face[halfedges.faces_of_edges(runs, np.flatnonzero(runs.counts == 1))] = True
        closed = np.bincount(comp, weights=open_face, minlength=n_labels) == 0
        U = V / unit_scale(V)  # a power of two: 1e300 or 1e-300 coordinates stay finite
        c = U[F[:, 0]].mean(axis=0)  # volumes about a point near the mesh, for precision
        a, b, d = (U[F[:, i]] - c for i in range(3))
        det = (
            a[:, 0] * (b[:, 1] * d[:, 2] - b[:, 2] * d[:, 1])
            + a[:, 1] * (b[:, 2] * d[:, 0] - b[:, 0] * d[:, 2])
            + a[:, 2] * (b[:, 0] * d[:, 1] - b[:, 1] * d[:, 0])
        )
        volume = np.bincount(comp, weights=np.where(flip, -det, det), minlength=n_labels)
        invert = np.where(closed, volume < 0, invert)
    flip ^= invert[comp]
    F2 = F.copy()
    F2[flip] = F2[flip][:, [0, 2, 1]]
    log = ""
    if flip.any():
        log = (
            f"orient_faces: flipped faces {format_indices(np.flatnonzero(flip))} in "
            f"{np.unique(comp[flip]).size} of {n_comp} components"
        )
    return _result(V.copy(), F2, n, m, flipped=flip, log=log)


def _split_fans(V: np.ndarray, F: np.ndarray, cut_edges: bool) -> RepairResult:
    n, m = V.shape[0], F.shape[0]
    runs = halfedges.sort_halfedges(F, n)
    bad = np.flatnonzero(runs.counts > 2)
    name = "split_nonmanifold_edges" if cut_edges else "split_nonmanifold_vertices"
    if bad.size and not cut_edges:
        raise NonManifoldError("cannot split vertices: " + nonmanifold_message(F, runs, bad))
    n_fans, fan = halfedges.corner_fans(F, runs)
    flat = F.ravel()
    vertex_of_fan = np.empty(n_fans, dtype=np.int64)
    vertex_of_fan[fan] = flat
    first_corner = np.full(n_fans, 3 * m, dtype=np.int64)
    np.minimum.at(first_corner, fan, np.arange(3 * m))
    order = np.lexsort((first_corner, vertex_of_fan))  # fans by vertex, then first corner
    v_sorted = vertex_of_fan[order]
    leading = np.ones(n_fans, dtype=bool)
    leading[1:] = v_sorted[1:] != v_sorted[:-1]
    extra = order[~leading]  # fans that get a new vertex, in (vertex, first corner) order
    new_id = np.empty(n_fans, dtype=np.int64)
    new_id[order[leading]] = v_sorted[leading]
    new_id[extra] = n + np.arange(extra.size)
    F2 = new_id[fan].reshape(m, 3)
    origin = np.concatenate([np.arange(n), vertex_of_fan[extra]])
    log = ""
    if extra.size:
        split = np.unique(vertex_of_fan[extra])
        log = (
            f"{name}: split vertices {format_indices(split)} into one copy per fan "
            f"({extra.size} new vertices {n}..{n + extra.size - 1})"
        )
        if cut_edges and bad.size:
            log += f"; cut along edges {[tuple(map(int, e)) for e in runs.edges[bad[:5]]]}"
            log += f" ({bad.size} in all) shared by more than two faces"
    if cut_edges:
        cut = halfedges.sort_halfedges(F2, origin.size)
        still = np.flatnonzero(cut.counts > 2)
        if still.size:
            named = [tuple(map(int, e)) for e in cut.edges[still[:5]]]
            raise NonManifoldError(
                f"{name}: after cutting, edges {named} "
                "are still shared by more than two faces (their faces meet around both ends "
                "through other edges). Fix: remove those faces."
            )
    return _result(V[origin], F2, n, m, vertex_origin=origin, vertex_map=np.arange(n), log=log)


def split_nonmanifold_vertices(vertices: npt.ArrayLike, faces: npt.ArrayLike) -> RepairResult:
    """Give each fan of faces around a vertex its own copy of the vertex.

    A vertex is manifold when its faces form one fan (an umbrella connected across edges).
    Two cones touching at their apex, or two sheets sharing one vertex, make a vertex with
    two fans; this splits it.

    Parameters
    ----------
    vertices : array_like (n, 3)
    faces : array_like of int (m, 3)
        Each edge in at most two faces; any orientation (fans are found by vertex
        identity, so this may run before :func:`orient_faces`).

    Returns
    -------
    RepairResult
        The first ``n`` new vertices are the old ones (``vertex_map`` is the identity); the
        fan containing a vertex's lowest corner (face ``t``, corner ``i``: ``3t + i``) keeps
        the old index, each other fan gets a new vertex appended at the end, in vertex
        order: ``vertex_origin[n:]`` (n' - n,) says which old vertex each copy duplicates.
        Faces keep their order (identity face maps).

    Raises
    ------
    NonManifoldError
        Some edge is in more than two faces; the message says whether duplicated faces
        cause it (:func:`remove_duplicate_faces`) or to call :func:`split_nonmanifold_edges`.
    """
    V, F = raw_arrays(vertices, faces)
    return _split_fans(V, F, cut_edges=False)


def split_nonmanifold_edges(vertices: npt.ArrayLike, faces: npt.ArrayLike) -> RepairResult:
    """Cut the faces apart along edges shared by more than two faces, then split every vertex.

    Faces are not joined across a non-manifold edge, so each face on it gets its own copy
    of the edge: a "book" of three pages on one spine becomes three separate pages with a
    boundary along the spine. Every vertex is then split per fan, as in
    :func:`split_nonmanifold_vertices` (which this includes).

    Parameters
    ----------
    vertices : array_like (n, 3)
    faces : array_like of int (m, 3)

    Returns
    -------
    RepairResult
        As for :func:`split_nonmanifold_vertices`.

    Raises
    ------
    NonManifoldError
        In the rare case where faces on a cut edge still meet around both of its ends
        through other edges, so the cut edge stays shared by more than two faces.

    Notes
    -----
    Duplicated faces also make edges non-manifold; remove them with
    :func:`remove_duplicate_faces` first, or the copies end up as separate loose triangles.
    """
    V, F = raw_arrays(vertices, faces)
    return _split_fans(V, F, cut_edges=True)


def flatten_spikes(
    vertices: npt.ArrayLike, faces: npt.ArrayLike, ratio: float = SPIKE_RATIO
) -> RepairResult:
    """Move a scan's spike vertices to the centroids of their rings (:mod:`fvf.mesh.spikes`).

    Opt-in (not in :data:`DEFAULT_REPAIR_STEPS`): it changes the geometry, and a sharp
    cone tip that belongs to the shape is a spike by its test too.

    Parameters
    ----------
    vertices : array_like (n, 3)
    faces : array_like of int (m, 3)
    ratio : float
        A vertex standing more than this many ring radii above its ring is a spike.

    Returns
    -------
    RepairResult
        The same faces and identity maps; the moved vertices are named in ``log``.
    """
    V, F = raw_arrays(vertices, faces)
    W, moved = flattened_spikes(V, F, ratio)
    log = ""
    if moved.size:
        log = (
            f"flatten_spikes: moved {moved.size} spike vertices {format_indices(moved)} to "
            "the centroids of their neighbours"
        )
    return _result(W, F.copy(), V.shape[0], F.shape[0], log=log)


#: Every repair by name, for :func:`repair_mesh`.
REPAIR_STEPS = {
    "remove_duplicate_vertices": remove_duplicate_vertices,
    "split_t_junctions": split_t_junctions,
    "remove_degenerate_faces": remove_degenerate_faces,
    "remove_duplicate_faces": remove_duplicate_faces,
    "split_nonmanifold_edges": split_nonmanifold_edges,
    "split_nonmanifold_vertices": split_nonmanifold_vertices,
    "orient_faces": orient_faces,
    "remove_unreferenced_vertices": remove_unreferenced_vertices,
    "flatten_spikes": flatten_spikes,
}

#: The order :func:`repair_mesh` uses by default: weld, close T-junctions, drop what welding
#: made degenerate or duplicate, split vertices, orient, drop orphans.
#: ``split_nonmanifold_edges`` (a cut that changes topology) is opt-in.
DEFAULT_REPAIR_STEPS = (
    "remove_duplicate_vertices",
    "split_t_junctions",
    "remove_degenerate_faces",
    "remove_duplicate_faces",
    "split_nonmanifold_vertices",
    "orient_faces",
    "remove_unreferenced_vertices",
)


def repair_mesh(
    vertices: npt.ArrayLike,
    faces: npt.ArrayLike,
    steps: Sequence[str] = DEFAULT_REPAIR_STEPS,
    *,
    tol: float = 0.0,
) -> RepairResult:
    """Apply named repairs in order and compose their maps.

    Parameters
    ----------
    vertices : array_like (n, 3)
    faces : array_like of int (m, 3)
    steps : sequence of str
        Names from :data:`REPAIR_STEPS`, applied left to right.
    tol : float
        Passed to :func:`remove_duplicate_vertices`.

    Returns
    -------
    RepairResult
        Maps from the input to the final arrays (see :meth:`RepairResult.then`); ``log``
        holds one line per step that changed something.

    Examples
    --------
    >>> import numpy as np, fvf
    >>> mesh = fvf.icosphere(1)
    >>> soup = mesh.vertices[mesh.faces].reshape(-1, 3)  # every face with its own vertices
    >>> fixed = fvf.repair_mesh(soup, np.arange(soup.shape[0]).reshape(-1, 3))
    >>> fixed.vertices.shape, fvf.TriMesh(fixed.vertices, fixed.faces).is_closed
    ((42, 3), True)
    """
    unknown = [s for s in steps if s not in REPAIR_STEPS]
    if unknown:
        raise ValueError(f"unknown repair steps {unknown}; choose from {list(REPAIR_STEPS)}")
    V, F = raw_arrays(vertices, faces)
    total = _result(V.copy(), F.copy(), V.shape[0], F.shape[0])
    for step in steps:
        kwargs = {"tol": tol} if step == "remove_duplicate_vertices" else {}
        total = total.then(REPAIR_STEPS[step](total.vertices, total.faces, **kwargs))
    return total
