"""A validation report for a mesh that may be broken: what ``fvf info`` prints.

:class:`fvf.TriMesh` stops at the first problem; :func:`mesh_report` collects what can be
said about arbitrary vertex and face arrays without raising, so a user sees every problem
at once, each with its indices and the :mod:`fvf.repair` function that fixes it.
"""

from __future__ import annotations

import warnings

import numpy as np
import numpy.typing as npt

from ..errors import DuplicateVertexWarning, FvfError, format_indices
from . import halfedges
from .defects import duplicate_faces, raw_arrays, repeats_vertex, zero_area_faces
from .repair import orient_faces, remove_duplicate_vertices, remove_unreferenced_vertices
from .trimesh import DEGENERATE_AREA_RTOL, TriMesh, validate_arrays

__all__ = ["mesh_report", "NEEDLE_ANGLE_DEG"]

#: Faces with a corner angle below this are reported as needles.
NEEDLE_ANGLE_DEG = 1.0


def _corner_angles(X: np.ndarray, F: np.ndarray) -> np.ndarray:
    """Corner angles in degrees, (m, 3); NaN for degenerate corners."""
    P = X[F]
    out = np.empty(F.shape)
    for i in range(3):  # the three corners, vectorized over faces
        a = P[:, (i + 1) % 3] - P[:, i]
        b = P[:, (i + 2) % 3] - P[:, i]
        with np.errstate(invalid="ignore", divide="ignore"):
            cos = np.einsum("ij,ij->i", a, b) / (
                np.linalg.norm(a, axis=1) * np.linalg.norm(b, axis=1)
            )
            out[:, i] = np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))
    return out


def _problem(kind: str, what: str, fix: str) -> str:
    return f"{kind}: {what}. Fix: {fix}"


def _find_problems(X: np.ndarray, F: np.ndarray, report: dict) -> list[str]:
    """Every repairable problem of finite, in-range arrays, each naming its repair."""
    problems = _vertex_problems(X, F, report)
    ok_faces = _face_problems(X, F, report, problems)
    _topology_problems(X, F[ok_faces], report, problems)
    return problems


def _vertex_problems(X: np.ndarray, F: np.ndarray, report: dict) -> list[str]:
    """Unreferenced vertices (a problem) and coincident ones (a hint)."""
    problems = []
    n = X.shape[0]
    used = np.zeros(n, dtype=bool)
    used[F.ravel()] = True
    unref = np.flatnonzero(~used)
    report["unreferenced_vertices"] = int(unref.size)
    if unref.size:
        problems.append(
            _problem(
                "UnreferencedVertexError",
                f"vertices {format_indices(unref)} belong to no face",
                "V, F, kept = fvf.remove_unreferenced_vertices(V, F)",
            )
        )
    welded = remove_duplicate_vertices(X, F)
    dup_v = np.flatnonzero(welded.vertex_origin[welded.vertex_map] != np.arange(n))
    report["duplicate_vertices"] = int(dup_v.size)
    if dup_v.size:  # legitimate after a split, so a hint and not a problem
        report["hints"] = _coincident_hints(F, dup_v, welded.vertex_origin[welded.vertex_map])
    return problems


def _coincident_hints(F: np.ndarray, dup: np.ndarray, rep: np.ndarray) -> list[str]:
    """What coincident vertices ``dup`` (each at the position of ``rep[dup]``) mean: a cut
    (both on a boundary: welding closes it) or a surface touching itself (welding would
    make a non-manifold vertex)."""
    edges = np.sort(F[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
    unique, count = np.unique(edges, axis=0, return_counts=True)
    size = max(int(F.max(initial=-1)), int(rep.max()), int(dup.max())) + 1
    boundary = np.zeros(size, dtype=bool)
    boundary[unique[count == 1].ravel()] = True
    cut = boundary[dup] & boundary[rep[dup]]
    hints = []
    if cut.any():
        hints.append(
            f"vertices {format_indices(dup[cut])} coincide with a lower-index vertex on "
            "the boundary: the surface is cut there (an unwelded soup, a seam, or a split "
            "vertex). To weld them: fvf.remove_duplicate_vertices(V, F), then run fvf "
            "info again"
        )
    if (~cut).any():
        hints.append(
            f"vertices {format_indices(dup[~cut])} coincide with a lower-index vertex, "
            "not both on a boundary: the surface touches itself there (two parts of a "
            "closed scan meeting at a point, or a split non-manifold vertex or edge); "
            "welding would make them non-manifold, so leave them as they are"
        )
    return hints


def _face_problems(X: np.ndarray, F: np.ndarray, report: dict, problems: list[str]) -> np.ndarray:
    """Degenerate and duplicate faces; returns the faces to check the topology of, bool (m,)."""
    repeats = repeats_vertex(F)
    flat = ~repeats & zero_area_faces(X, F, DEGENERATE_AREA_RTOL)
    report["degenerate_faces"] = int(repeats.sum() + flat.sum())
    if repeats.any():
        problems.append(
            _problem(
                "RepeatedVertexError",
                f"faces {format_indices(np.flatnonzero(repeats))} repeat a vertex",
                "fvf.remove_degenerate_faces(V, F)",
            )
        )
    if flat.any():
        problems.append(
            _problem(
                "DegenerateFaceError",
                f"faces {format_indices(np.flatnonzero(flat))} have zero area",
                "fvf.remove_degenerate_faces(V, F) (it may open a crack; see docs/repair.md)",
            )
        )
    duplicate, reversed_ = duplicate_faces(F)
    report["duplicate_faces"] = int(duplicate.sum())
    if duplicate.any():
        problems.append(
            _problem(
                "DuplicateFaces",
                f"faces {format_indices(np.flatnonzero(duplicate))} repeat an earlier face's "
                f"vertices ({int(reversed_.sum())} in the opposite order)",
                "fvf.remove_duplicate_faces(V, F)",
            )
        )
    return ~(repeats | duplicate)


def _topology_problems(X: np.ndarray, G: np.ndarray, report: dict, problems: list[str]) -> None:
    """Non-manifold edges, then non-manifold vertices and orientation, of the faces ``G``."""
    n = X.shape[0]
    runs = halfedges.sort_halfedges(G, n)
    bad = np.flatnonzero(runs.counts > 2)
    report["nonmanifold_edges"] = int(bad.size)
    if bad.size:
        problems.append(
            _problem(
                "NonManifoldError",
                f"edges {[tuple(map(int, e)) for e in runs.edges[bad[:5]]]} ({bad.size} in all) "
                "are shared by more than two faces (duplicates aside)",
                "fvf.split_nonmanifold_edges(V, F) (cuts the faces apart along them)",
            )
        )
        report["orientation"] = "unknown (non-manifold edges)"
        return
    n_fans, fan = halfedges.corner_fans(G, runs)
    vertex_of_fan = np.empty(n_fans, dtype=np.int64)
    vertex_of_fan[fan] = G.ravel()
    fans = np.bincount(vertex_of_fan, minlength=n)
    nm = np.flatnonzero(fans > 1)
    report["nonmanifold_vertices"] = int(nm.size)
    if nm.size:
        problems.append(
            _problem(
                "NonManifoldError",
                f"vertices {format_indices(nm)} join {int(fans.max())} separate fans of faces",
                "fvf.split_nonmanifold_vertices(V, F)",
            )
        )
    report["orientation"] = _orientation(X, G, problems)


def _orientation(X: np.ndarray, G: np.ndarray, problems: list[str]) -> str:
    """ "consistent", "inconsistent" or "non-orientable" (edge-manifold faces ``G``)."""
    try:
        oriented = orient_faces(X, G, outward=False)
    except FvfError as exc:
        problems.append(f"{type(exc).__name__}: {exc}")
        return "non-orientable"
    if not oriented.changed:
        return "consistent"
    problems.append(
        _problem(
            "OrientationError",
            f"faces {format_indices(oriented.face_origin[oriented.flipped])} are oriented "
            "against their neighbours",
            "fvf.orient_faces(V, F)",
        )
    )
    return "inconsistent"


def mesh_report(vertices: npt.ArrayLike, faces: npt.ArrayLike) -> dict:
    """Everything checkable about a triangle mesh, without raising.

    Parameters
    ----------
    vertices : array_like (n, 3)
    faces : array_like of int (m, 3)

    Returns
    -------
    dict
        ``ok`` (bool: no problems; a TriMesh can then be built as is), ``problems`` (list of
        one-line messages ``"<ErrorType>: <what, with indices>. Fix: <repair call>"``, each
        fix naming a function of :mod:`fvf.repair`), and, where they could be computed:
        ``n_vertices``, ``n_faces``, ``unreferenced_vertices``, ``duplicate_vertices``,
        ``degenerate_faces``, ``duplicate_faces``, ``nonmanifold_edges``,
        ``nonmanifold_vertices``, ``hints`` (when vertices coincide: not a problem, since
        a split leaves coincident copies, but the usual sign of an unwelded soup),
        ``orientation`` ("consistent", "inconsistent",
        "non-orientable"), ``min_angle_deg``, ``needle_faces`` (count below
        :data:`NEEDLE_ANGLE_DEG`), and, when the only problem is unreferenced vertices or
        there is none, the topology of the mesh without them: ``manifold``, ``closed``,
        ``components``, ``euler_characteristic``, ``genus``, ``boundary_loops``.
    """
    report: dict = {"ok": False, "problems": []}
    X = np.asarray(vertices)
    F = np.asarray(faces)
    try:
        X, F = raw_arrays(X, F)
        if F.shape[0] == 0 or X.shape[0] == 0:
            validate_arrays(X, F)  # raises MeshShapeError for the empty mesh
    except FvfError as exc:
        report["problems"].append(f"{type(exc).__name__}: {exc}")
        return report
    report["n_vertices"], report["n_faces"] = X.shape[0], F.shape[0]
    finite = np.isfinite(X).all(axis=1)
    if not finite.all():
        report["problems"].append(
            f"NonFiniteError: vertices {format_indices(np.flatnonzero(~finite))} have NaN or "
            "inf coordinates. Fix: correct them in the source (no automatic repair: their "
            "positions are unknown)"
        )
        return report
    problems = _find_problems(X, F, report)
    report["problems"] = problems
    angles = _corner_angles(X, F)
    report["min_angle_deg"] = float(np.nanmin(angles)) if np.isfinite(angles).any() else 0.0
    needles = np.flatnonzero(np.nan_to_num(angles, nan=0.0).min(axis=1) < NEEDLE_ANGLE_DEG)
    report["needle_faces"] = int(needles.size)
    if needles.size:
        report["needle_face_ids"] = needles[:20].tolist()
        report.setdefault("hints", []).append(
            f"faces {format_indices(needles)} are needles (a corner angle below "
            f"{NEEDLE_ANGLE_DEG:g} degree, the smallest {report['min_angle_deg']:.2g}): "
            "gradients and cotangent weights on them are ill-conditioned, so fields and "
            "flows can be inaccurate there. Fix: remesh, or collapse their short edges"
        )
    if any(not p.startswith("UnreferencedVertexError") for p in problems):
        report["manifold"] = not (
            report.get("nonmanifold_edges") or report.get("nonmanifold_vertices")
        )
        return report
    X, F, _ = remove_unreferenced_vertices(X, F)
    try:
        with warnings.catch_warnings():  # a soup is reported as a hint, not a warning
            warnings.simplefilter("ignore", DuplicateVertexWarning)
            mesh = TriMesh(X, F)
    except FvfError as exc:  # pragma: no cover - every TriMesh check is mirrored above
        problems.append(f"{type(exc).__name__}: {exc}")
        return report
    report.update(
        ok=not problems,
        manifold=True,
        closed=mesh.is_closed,
        components=mesh.n_components,
        euler_characteristic=mesh.euler_characteristic,
        boundary_loops=mesh.n_boundary_loops,
    )
    if mesh.n_components == 1:
        report["genus"] = mesh.genus
    return report
