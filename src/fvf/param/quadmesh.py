r"""The quad mesh of a cross field: seamless parameterization, integer-grid extraction, a gate.

:func:`quad_mesh` meshes each connected component on its own, at one target edge length
h, through a list of attempts (:func:`_plans`), and returns the first result that passes
:func:`fvf.param.quad_validity.check_quad_mesh`; an invalid quad mesh is never returned.
"""

from __future__ import annotations

import contextlib
import dataclasses
import warnings
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from typing import Any, Literal, cast

import numpy as np
import numpy.typing as npt

from ..errors import (
    DenseFeaturesWarning,
    DistortedQuadsWarning,
    FvfError,
    ParameterError,
    ProblemSizeError,
    QuadCountRaisedWarning,
    QuadExtractionError,
    QuadFallbackWarning,
    QuadMeshError,
    SmallComponentWarning,
    UndeclaredCacheKeyError,
    VerticesWeldedWarning,
    format_indices,
    user_stacklevel,
)
from ..mesh.convert import takes_mesh
from ..mesh.nfield import require_order
from ..mesh.open_seams import weld_open_seams
from ..mesh.trimesh import TriMesh
from ..numerics.budget import check_memory
from ..numerics.progress import ProgressCallback, make_progress
from .caps import capped, cut_caps, doubled, snap_boundary, split_pairs
from .decimation import decimated_for_quads
from .extraction import extract_quads
from .features import (
    CREASE_ANGLE,
    DENSE_FEATURES,
    MIN_CHAIN,
    feature_density,
    feature_edge_ids,
    sharp_edges,
    transferred_features,
)
from .frame_field import Alignment
from .quad_failures import describe_places, failure_places, resolving_edge
from .quad_folds import (
    MAX_RINGS,
    STEPS_PER_RING,
    Passes,
    closest_surface_points,
    folded_quads,
    untangle_quads,
)
from .quad_parts import Part, component_parts, join_parts
from .quad_result import QuadMeshResult
from .quad_validity import check_quad_mesh, topology_signature
from .quality import corner_distortion, quad_boundary_vertices
from .remesh import (
    FINE_REMESH_FRACTION,
    REMESH_FRACTION,
    Remesher,
    needs_remesh,
    remesh_for_quads,
)
from .seamless import SeamlessParameterization, edge_length_for, seamless_parameterization
from .sizing import curvature_log_scale
from .split_quads import split_quad_mesh
from .strips import has_thin_strips

__all__ = ["quad_mesh", "MIN_COMPONENT_QUADS", "MAX_QUADS_PER_FACE", "QUAD_BYTES"]

#: What :func:`quad_mesh` gives a component whose attempts all failed.
Fallback = Literal["error", "split"]
FALLBACKS = ("error", "split")
#: A component smaller than this many target quads (area / h²) is meshed at its own,
#: smaller edge length √(area / MIN_COMPONENT_QUADS); if that fails, it is left out.
MIN_COMPONENT_QUADS = 8
#: When every attempt fails at parts narrower than a quad edge, the component is tried
#: again with quads that resolve them if that asks for at most this many times the quads
#: (:mod:`fvf.param.quad_failures`) ...
MAX_RAISE = 8.0
#: ... with the first this many attempts of the list at that size.
FINER_ATTEMPTS = 3
#: Attempts with quads sized by curvature (:mod:`fvf.param.sizing`) are made when the
#: sizing asks somewhere for quads this many times shorter than h.
SIZED_REFINEMENT = 1.2
#: A sized attempt that makes more than this many times the quads asked says so.
SIZED_WARN = 1.5
#: An open component whose domes would hold more than this many times its area is closed
#: by its mirror image first (:func:`fvf.param.caps.doubled`, which adds exactly its
#: area), by domes only if that fails; below it, domes first (a helical ribbon's domes hold
#: 9.4 times the ribbon and every attempt on them failed; a flat disk's hold 2 times it,
#: and its quads' corners are 5° from square on domes, 11° on its mirror image).
DOME_AREA_LIMIT = 4.0
#: Ring spacing of the domes that close open components, in quad edges.
CAP_SPACING = 0.5
#: A valid attempt whose corner angles are this far from 90° (degrees) at the 95th
#: percentile is distorted: the next attempts are tried, and it is returned only when none
#: of them is valid and undistorted (valid results measure 3–20°; an exporter's fan
#: triangles around a hole with its rims as iso-lines gave 60°).
DISTORTED_CORNERS = 45.0
#: Each retry with more quads shrinks h by this factor (1.5× the quads).
MORE_QUADS = 1.0 / np.sqrt(1.5)
#: At most this many quads per input triangle (area / h² over the face count): finer quads
#: only resample the flat triangles (a 12-triangle cube still gets 120,000 quads).
MAX_QUADS_PER_FACE = 10_000
#: Peak memory per target quad, bytes, measured on an icosphere at 1k-50k quads (0.85 GB
#: at 50k: remeshing at the quad scale, parameterization, extraction).
QUAD_BYTES = 16_384


def _check_quad_count(mesh: TriMesh, h: float, target_faces: int | None) -> None:
    """Refuse, before any work, a quad count beyond what the input carries
    (:data:`MAX_QUADS_PER_FACE`) or the machine's memory holds (:data:`QUAD_BYTES` each):
    :class:`fvf.ProblemSizeError`."""
    quads = mesh.total_area / (h * h)
    asked = f"target_faces={target_faces}" if target_faces is not None else f"edge_length={h:g}"
    limit = MAX_QUADS_PER_FACE * mesh.n_faces
    if quads > limit:
        raise ProblemSizeError(
            f"fvf.quad_mesh with {asked} asks for about {quads:.3g} quads from {mesh.n_faces} "
            f"triangles; at most {MAX_QUADS_PER_FACE} quads per input triangle ({limit}) "
            "are made, finer quads would only resample the flat triangles. Fix: ask for "
            f"at most {limit} quads, or subdivide the input first"
        )
    check_memory(
        f"fvf.quad_mesh with {asked} (about {quads:.3g} quads)",
        quads * QUAD_BYTES,
        "ask for fewer quads, or run on a machine with more memory",
    )


@dataclass(frozen=True)
class _Plan:
    remeshed: bool
    align: Alignment
    h: float
    isolines: bool = False
    sized: bool = False
    strips: bool = False
    fine: bool = False  # remeshed at FINE_REMESH_FRACTION h, not REMESH_FRACTION h
    decimated: bool = False  # the input surface decimated (set as the plan runs)

    def __str__(self) -> str:
        surface = ("finely remeshed" if self.fine else "remeshed") if self.remeshed else "input"
        surface = "decimated" if self.decimated else surface
        lines = ", features as iso-lines" if self.isolines else ""
        strips = ", thin strips one quad across" if self.strips else ""
        sized = ", sized by curvature" if self.sized else ""
        return f"{surface} surface, {self.align} field{lines}{strips}{sized}, h = {self.h:.4g}"


def _plans(
    part: Part,
    h: float,
    align: Alignment,
    retry: bool,
    remesh: bool | str,
    features: bool,
    rims_only: bool = False,
) -> list[_Plan]:
    """The attempts for one component, in order (``docs/quads.md``); with ``rims_only``
    (the only features are the rims of the domes over its holes: a scan with holes) those
    with the features as iso-lines follow the first without."""
    if part.cap is not None and part.cap.mirrored:
        return _mirrored_plans(h, align, retry)
    if not retry:
        return [_Plan(remesh is True, align, h, features)]
    other: Alignment = "smooth" if align == "curvature" else "curvature"
    can = remesh != "never"
    why = needs_remesh(part.closed, h) if can else None
    skip_input = remesh is True or (why is not None and "angle" in why)  # slivers: remesh first
    first = [] if skip_input else [_Plan(False, align, h)]
    first += [_Plan(can, align, h)]
    lines = []
    fine = [_Plan(True, align, h, fine=True)] if can else []
    for p in first + fine if features else []:  # features as iso-lines; then strips stretched
        lines += [dataclasses.replace(p, isolines=True)]
        lines += [dataclasses.replace(p, isolines=True, strips=True)]
    plain = first + [_Plan(can, other, h)]
    plans = plain + lines if rims_only else lines + plain
    # quads smaller where the surface turns faster (skipped where nothing is that curved)
    plans += [dataclasses.replace(p, align="curvature", sized=True) for p in first]
    for k, finer in enumerate((h * MORE_QUADS, h * MORE_QUADS**2)):
        # the features as iso-lines again at more quads: holes through a floor thinner
        # than a quad need their cones a quad edge apart (thin strips stretched, or plain)
        held = [_Plan(can, "curvature", finer, sized=True)]
        held += [_Plan(can, other, finer)] if k == 0 else []
        iso = [_Plan(can, align, finer, isolines=True, strips=True)] if features else []
        plans += held + iso if rims_only else iso + held
    return list(dict.fromkeys(plans))


def _mirrored_plans(h: float, align: Alignment, retry: bool) -> list[_Plan]:
    """The attempts for a component closed by its mirror image: on the input surface (the
    remeshers and the decimation would join or move the two sheets, which lie on each
    other), its boundary loops as iso-lines (else quads would fold across them); the
    smoothest field, then the curvature-aligned one (the curvature at the loops is the
    fold's, and it pulled the cones of a ribbon's corners off them), then thin strips
    stretched, then 1.5× and 2.25× the quads. Without ``retry``, one attempt with
    ``align``."""
    if not retry:
        return [_Plan(False, align, h, isolines=True)]
    plans = []
    for k, edge in enumerate((h, h * MORE_QUADS, h * MORE_QUADS**2)):
        fields: tuple[Alignment, ...] = ("smooth", "curvature") if k == 0 else ("smooth",)
        plans += [_Plan(False, a, edge, isolines=True) for a in fields]
        plans += [_Plan(False, "smooth", edge, isolines=True, strips=True)]
    return plans


def _surface(part: Part, plan: _Plan, surfaces: dict, opts: dict) -> TriMesh:
    """The closed component, or it remeshed for quads of edge ``plan.h`` (kept in
    ``surfaces`` for the next attempts, and so is the message of a remeshing that failed:
    the next attempt on that surface raises it again without remeshing), as ``plan``
    asks."""
    if plan.decimated:
        return surfaces[("decimated", round(plan.h, 12))]
    if not plan.remeshed:
        return part.closed
    fraction = FINE_REMESH_FRACTION if plan.fine else REMESH_FRACTION
    key = (round(plan.h, 12), fraction)
    if key not in surfaces:
        try:
            surfaces[key] = remesh_for_quads(
                part.closed,
                plan.h,
                crease_angle=opts["crease_angle"],
                method=opts["remesher"],
                fraction=fraction,
            )
        except QuadExtractionError as exc:  # kept: the next plan on it fails at once
            surfaces[key] = str(exc)
    if isinstance(surfaces[key], str):  # (the L bracket at 10,000 quads: 30 s per try)
        raise QuadExtractionError(surfaces[key])
    return surfaces[key]


def _sizing(part: Part, plan: _Plan, surfaces: dict, opts: dict) -> tuple[TriMesh, Any]:
    """The surface of ``plan`` and its conformal log scale (n,) for quads sized by
    curvature (:mod:`.sizing`), None when the plan is not sized or the sizing asks
    nowhere for quads :data:`SIZED_REFINEMENT` times shorter than h (measured on the
    surface remeshed for h: a CAD part's sharp edges show their curvature there), or the
    component's sharp edges are denser than the quads (:func:`_own_features`: its thread's
    curvature would ask for quads at the thread's scale everywhere)."""
    surface = _surface(part, plan, surfaces, opts)
    if not plan.sized:
        return surface, None
    key = ("sizing", round(plan.h, 12), plan.remeshed, plan.fine, plan.decimated)
    if key not in surfaces:
        dense = _density(part, plan.h, opts) is not None  # meshed as smooth: unsized
        s = np.zeros(surface.n_vertices) if dense else curvature_log_scale(surface, plan.h)
        surfaces[key] = s if float(s.max(initial=0.0)) > np.log(SIZED_REFINEMENT) else None
    return surface, surfaces[key]


def _density(part: Part, h: float, opts: dict) -> float | None:
    """:func:`fvf.param.features.feature_density` of the component's sharp edges where it
    is above :data:`fvf.param.features.DENSE_FEATURES` at quad edge ``h`` (they are then
    no features: :func:`_own_features`, found here if not yet), else None."""
    _features(part, part.closed, h, opts)
    return opts.get("dense features", {}).get(_part_key(part, h))


def _part_key(part: Part, h: float) -> tuple[int, float, str]:
    """The key of what is found once per component, closure and quad edge (its own
    features, their density)."""
    return (part.label, round(h, 12), _closure_name(part))


def _resolved(
    part: Part, plan: _Plan, plans: list[_Plan], surfaces: dict, opts: dict
) -> _Plan | None:
    """``plan`` as it runs: a sized plan whose sizing is trivial (:func:`_sizing`) is its
    plan of one size, or None (skipped) when that one is in ``plans`` too; likewise a
    thin-strips plan without a thin strip (:func:`fvf.param.strips.has_thin_strips`) is
    the plan without strips, or skipped; a plan
    on the input surface runs on it decimated where the input is far finer than the quads
    (:mod:`.decimation`)."""
    decimate = opts["remesh"] != "never"
    if not plan.remeshed and decimate and _decimated(part, plan.h, surfaces, opts):
        plan = dataclasses.replace(plan, decimated=True)
    if plan.strips and not _has_strips(part, plan, surfaces, opts):
        plain = dataclasses.replace(plan, strips=False)
        return None if _planned(plain, plans) else plain
    if not plan.sized or _sizing(part, plan, surfaces, opts)[1] is not None:
        return plan
    uniform = dataclasses.replace(plan, sized=False)
    return None if _planned(uniform, plans) else uniform


def _planned(plan: _Plan, plans: list[_Plan]) -> bool:
    """Whether ``plan`` (decimated or not as it runs) is in the list as planned."""
    return dataclasses.replace(plan, decimated=False) in plans


def _decimated(part: Part, h: float, surfaces: dict, opts: dict) -> bool:
    """Whether the closed component, decimated for quads of edge ``h``
    (:func:`fvf.param.decimation.decimated_for_quads`, kept in ``surfaces``), replaces it:
    not where it has sharp features (the collapses move creases; the rims of its domes
    do not count), nor when it is closed by its mirror image (the collapses would move the
    two sheets, which lie on each other, apart)."""
    key = ("decimated", round(h, 12))
    if key not in surfaces:
        found = _features(part, part.closed, h, opts)
        sharp = _featured(found) and not _only_rims(part, found)
        sharp = sharp or (part.cap is not None and part.cap.mirrored)
        surfaces[key] = None if sharp else decimated_for_quads(part.closed, h)
    return surfaces[key] is not None


def _has_strips(part: Part, plan: _Plan, surfaces: dict, opts: dict) -> bool:
    """Whether the features of ``plan``'s surface bound a strip thin enough to stretch."""
    surface = _surface(part, plan, surfaces, opts)
    features = _plan_features(part, plan, surfaces, opts)
    return features is not None and has_thin_strips(surface, features, plan.h)


def _plan_features(part: Part, plan: _Plan, surfaces: dict, opts: dict) -> np.ndarray | None:
    """:func:`_features` on ``plan``'s surface, kept in ``surfaces`` for the next attempts
    on it (the thin-strips check and each attempt ask for them)."""
    key = ("features", round(plan.h, 12), plan.remeshed, plan.fine, plan.decimated)
    if key not in surfaces:
        surfaces[key] = _features(part, _surface(part, plan, surfaces, opts), plan.h, opts)
    return surfaces[key]


def _attempt(
    part: Part,
    plan: _Plan,
    surfaces: dict,
    field: np.ndarray | None,
    opts: dict,
    report: ProgressCallback,
) -> tuple[
    np.ndarray, np.ndarray, np.ndarray, SeamlessParameterization, TriMesh, np.ndarray | None
]:
    """One try: (V, Q, vertex_faces on the component, parameterization, surface, the
    quads folded at V by the gate's test or None when not known)."""
    surface, size = _sizing(part, plan, surfaces, opts)
    f = None if field is None else _transfer_field(part.mesh, surface, field)
    features = _plan_features(part, plan, surfaces, opts)
    param = seamless_parameterization(
        surface,
        field=f,
        edge_length=plan.h,
        align=plan.align,
        features=features,
        feature_isolines=plan.isolines,
        thin_strips=plan.strips,
        sizing=size,
        **(_without_tidying(opts["seamless"]) if plan.strips else opts["seamless"]),
    )
    report("quad extraction", 0, 1)
    try:
        qm = extract_quads(surface, param.uv)
    except QuadExtractionError as exc:
        exc.where = surface.face_centroids[param.flipped]
        raise
    elsewhere = surface is not part.mesh  # the quads are then judged on the input
    mirrored = part.cap is not None and part.cap.mirrored  # untangled on the input only
    V, vf, Q, folds = qm.vertices, qm.vertex_face, qm.quads, None
    if not mirrored:  # the mirror image lies on the input: its closest faces are ambiguous
        repair = untangle_quads(
            surface, V, Q, vf, max_steps=opts["steps"], passes="first" if elsewhere else "both"
        )
        V, vf, folds = repair.vertices, repair.vertex_face, repair.verdict
    report("quad extraction", 1, 1)
    if part.cap is not None:
        V, Q, vf = cut_caps(part.cap, V, Q, vf)
    on_surface = V
    if elsewhere:
        vf, V = closest_surface_points(part.mesh, V, exact=True)
        passes: Passes = "both" if mirrored else "verdict"
        back = untangle_quads(part.mesh, V, Q, vf, max_steps=opts["steps"], passes=passes)
        V, vf, folds = back.vertices, back.vertex_face, back.verdict
    if part.cap is not None:
        V, vf = _snapped(part.mesh, V, Q, vf, on_surface)
        folds = None
    return (
        np.ascontiguousarray(V, np.float64),
        np.ascontiguousarray(Q, np.int64),
        vf,
        param,
        surface,
        folds,
    )


def _without_tidying(options: dict) -> dict:
    """The seamless options of a thin-strips attempt: its cones are not tidied. Across a
    wall thinner than a quad the cones of its two faces sit one above the other, closer
    than the tidying radius h, and moving them apart shears the wall's one row of quads."""
    return {**options, "cone_cancel_radius": 0.0}


def _features(part: Part, surface: TriMesh, h: float, opts: dict) -> np.ndarray | None:
    """Edge ids of ``surface`` the field is held along: the component's features
    (:func:`_own_features`, found once per quad edge) carried over to ``surface``."""
    found = opts.setdefault("own features", {})
    key = _part_key(part, h)
    if key not in found:
        found[key] = _own_features(part, h, opts)
    edges = found[key]
    if edges is None or surface is part.closed:
        return edges
    return transferred_features(part.closed, edges, surface, opts["crease_angle"], h)


def _own_features(part: Part, h: float, opts: dict) -> np.ndarray | None:
    """Edge ids of the closed component: its sharp edges (none where they are denser than
    the quads, :data:`fvf.param.features.DENSE_FEATURES`: kept in ``opts`` for
    :func:`_density`), the rims of its domes and the user's feature edges (None when
    there are no features to look for)."""
    mesh = part.closed
    found = []
    if opts["features"]:
        sharp = sharp_edges(mesh, opts["crease_angle"], MIN_CHAIN * h)
        density = feature_density(mesh, sharp, h)
        if density > DENSE_FEATURES:  # a thread, a knurl: texture at this quad size
            opts.setdefault("dense features", {})[_part_key(part, h)] = density
        else:
            found.append(sharp)
    if part.cap is not None:
        found.append(part.cap.rim)
    if opts["user_edges"] is not None:  # ids of the whole input's edges -> the part's
        whole = opts["whole"]
        pairs = whole.edges[opts["user_edges"]]
        local = np.full(whole.n_vertices, -1, dtype=np.int64)
        local[part.vertices] = np.arange(part.vertices.size)
        mine = local[pairs]
        mine = mine[(mine >= 0).all(axis=1)]
        if part.cap is not None:  # the halves of a chord the mirror image split
            mine = split_pairs(part.cap, mine)
        found.append(feature_edge_ids(mesh, mine))
    if not found:
        return None
    return np.unique(np.concatenate(found))


def _snapped(
    mesh: TriMesh, V: np.ndarray, Q: np.ndarray, vf: np.ndarray, on_surface: np.ndarray
) -> tuple:
    """:func:`fvf.param.caps.snap_boundary`, undone at the corners of quads it folds; at
    the corners of quads that still have two corners at one point (two quad vertices
    beside a dome, projected onto the same convex corner of the input's boundary), the
    positions on the meshed surface ``on_surface`` (k, 3), just outside the boundary."""
    W, wf = snap_boundary(mesh, V, Q, vf)
    folded = folded_quads(mesh, W, Q)
    if folded.size:
        back = np.unique(Q[folded])
        W[back], wf[back] = V[back], vf[back]
    P = W[Q]
    shortest = np.linalg.norm(P - np.roll(P, -1, axis=1), axis=2).min(axis=1)
    flat = shortest <= 1e-9 * max(float(np.ptp(W, axis=0).max()), 1e-300)
    if flat.any():
        rim = np.intersect1d(np.unique(Q[flat]), quad_boundary_vertices(Q))
        W[rim] = on_surface[rim]
    return W, wf


def _transfer_field(mesh: TriMesh, surface: TriMesh, field: np.ndarray) -> np.ndarray:
    """A per-face field of ``mesh`` on ``surface``: the value at the closest input face."""
    if surface is mesh:
        return field
    face, _ = closest_surface_points(mesh, surface.face_centroids)
    return surface.project_tangent(field[face])


def _mesh_part(
    part: Part,
    plans: list[_Plan],
    field: np.ndarray | None,
    opts: dict,
    report: ProgressCallback,
    surfaces: dict | None = None,
    distorted_ok: bool = True,
) -> tuple:
    """The first attempt whose quads pass the gate, or QuadMeshError listing them all;
    ``surfaces`` keeps the remeshed surfaces (and what is found on them) for later calls
    on the same closed component. When only distorted quads were valid, they are returned
    with a warning, or (not ``distorted_ok``) raised as :class:`_OnlyDistorted`."""
    log: list[str] = []
    spots: list[np.ndarray] = []  # where each attempt failed (module quad_failures)
    surfaces = {} if surfaces is None else surfaces
    want = topology_signature(part.mesh.n_vertices, part.mesh.faces)
    best = None
    distorted: tuple | None = None  # the first valid but distorted result
    tried = 0
    for planned in plans:
        tried += 1
        plan: _Plan | None = None
        try:
            plan = _resolved(part, planned, plans, surfaces, opts)
            if plan is None:
                tried -= 1
                continue
            if tried > 1:
                report(f"component {part.label}: attempt {tried} ({plan})", 0, 1)
                report(f"component {part.label}: attempt {tried} ({plan})", 1, 1)
            with _captured(opts["retry"]):
                V, Q, vf, param, surface, folds = _attempt(
                    part, plan, surfaces, field, opts, report
                )
        except (ParameterError, UndeclaredCacheKeyError):
            raise  # the caller's option, or a bug: not a reason to try another way
        except (ValueError, RuntimeError, ArithmeticError, np.linalg.LinAlgError) as exc:
            # resolving a sized plan remeshes: if that fails, the plan as planned failed
            log.append(f"{plan or planned}: {type(exc).__name__}: {_first_line(exc)}")
            where = getattr(exc, "where", None)
            spots.append(np.zeros((0, 3)) if where is None else np.asarray(where))
            continue
        verdict = check_quad_mesh(part.mesh, V, Q, signature=want, folded=folds)
        if verdict.valid:
            corners = corner_distortion(V, Q)
            if corners <= DISTORTED_CORNERS:
                log.append(f"{plan}: valid, {Q.shape[0]} quads")
                return V, Q, vf, param, surface, verdict, log
            log.append(f"{plan}: valid but distorted, {Q.shape[0]} quads, {corners:.0f}°")
            distorted = distorted or (V, Q, vf, param, surface, verdict, log, corners)
            continue
        log.append(f"{plan}: {Q.shape[0]} quads, invalid: {verdict}")
        spots.append(V[Q[verdict.folded]].mean(axis=1))
        best = best or (V, Q)
    if distorted is not None and distorted_ok:
        *made, corners = distorted
        _warn_distorted(part, corners)
        return tuple(made)
    places = failure_places(part.mesh, spots, plans[0].h)
    message = (
        f"no valid quad mesh of component {part.label} ({part.mesh.n_faces} triangles) after "
        f"{tried} attempts:\n  "
        + "\n  ".join(log)
        + "\n"
        + describe_places(places, tried, plans[0].h, part.mesh.total_area)
        + _advice(opts)
    )
    if distorted is not None:
        raise _OnlyDistorted(message, distorted, attempts=tuple(log), places=tuple(places))
    raise QuadMeshError(message, attempts=tuple(log), best=best, places=tuple(places))


class _OnlyDistorted(QuadMeshError):
    """No attempt gave undistorted valid quads; ``distorted`` holds the first valid but
    distorted result (what :func:`_mesh_part` returns, then its corner error), kept while
    another closure is tried."""

    def __init__(self, message: str, distorted: tuple, **kwargs: Any) -> None:
        super().__init__(message, **kwargs)
        self.distorted = distorted


@contextlib.contextmanager
def _captured(quiet: bool) -> Iterator[list]:
    """Warnings of an attempt kept for its log entry (``quiet``) or passed on."""
    if not quiet:
        yield []
        return
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        yield caught


def _first_line(exc: BaseException, limit: int = 240) -> str:
    """What went wrong in an attempt, for its log line: the error's first line up to its
    first ``"; "`` (the advice after it is given once, at the end of the error), cut at a
    word within ``limit`` characters."""
    text = str(exc).strip().splitlines()
    first = text[0].split("; ")[0] if text else ""
    if len(first) <= limit:
        return first
    return first[:limit].rsplit(" ", 1)[0] + " …"


def _advice(opts: dict) -> str:
    tip = "try another target (fvf quad --faces N), or align='smooth'"
    tip += (
        "; or fallback='split' (fvf quad --fallback split) for valid quads there that follow "
        "no field (the triangles split into three quads each)"
    )
    if opts["remesher"] in ("auto", "subdivide"):
        from .remesh import available_remesher

        if available_remesher() != "pymeshlab":
            tip += (
                "; install the remesher (pip install 'fvf[remesh]') for inputs with bad triangles"
            )
    return "What to try: " + tip + "."


@takes_mesh
def quad_mesh(
    mesh: TriMesh,
    *,
    target_faces: int | None = None,
    field: npt.ArrayLike | None = None,
    edge_length: float | None = None,
    align: Alignment = "curvature",
    retry: bool = True,
    remesh: bool | str = "auto",
    remesher: Remesher = "auto",
    crease_angle: float | None = CREASE_ANGLE,
    features: npt.ArrayLike | None = None,
    return_parameterization: bool = False,
    fold_repair_steps: int = STEPS_PER_RING * (MAX_RINGS + 1),
    fallback: Fallback = "error",
    **options: Any,
) -> QuadMeshResult:
    """A valid pure-quad mesh whose edges follow a cross field (the chapter's Fig. 1), or an error.

    Each connected component is meshed on its own at one target edge length h: a
    seamless parameterization (:func:`fvf.seamless_parameterization`), its integer grid
    pulled back (:func:`fvf.param.extraction.extract_quads`), quads folded in 3D untangled
    on the surface (:func:`fvf.param.quad_folds.untangle_quads`; when the surface was a
    remeshed copy, once more on the input after the quads are put on it). The result must pass
    :func:`fvf.param.quad_validity.check_quad_mesh`: pure quads, manifold, consistently
    oriented, the input's χ and boundary loops per component, no folded quad, within one
    quad edge of the input. Otherwise the next attempt runs (``docs/quads.md``): the input
    remeshed at the quad scale (:mod:`fvf.param.remesh`; first, when its triangles are
    too coarse or too thin), the other default field, 1.5× and 2.25× the quads. When
    every attempt fails, :class:`fvf.QuadMeshError` lists them; nothing invalid is ever
    returned.

    Parameters
    ----------
    mesh : TriMesh
        Closed components (boundary loops: :class:`fvf.ParameterizationInputError`).
    target_faces : int, optional
        Approximate number of quads in all (default m / 10); exclusive with
        ``edge_length``. h = √(area / target_faces).
    field : array_like (m, 3), optional
        Cross field, one representative tangent vector per input face (default:
        curvature aligned, or the smoothest with ``align="smooth"``).
    edge_length : float, optional
        Target quad edge length h instead of a count.
    align : {"curvature", "smooth"}
    retry : bool
        Try the other attempts when the first fails (default). ``False``: one attempt,
        on the input (remeshed only with ``remesh=True``); its warnings reach the caller.
    remesh : {"auto", True, "never"}
        ``"auto"``: remesh when the input asks for it or an attempt on it failed;
        ``True``: always; ``"never"``: never.
    remesher : {"auto", "pymeshlab", "subdivide"}
        :func:`fvf.param.remesh.remesh_for_quads`.
    crease_angle : float or None
        Dihedral angle (degrees) above which an edge is a sharp feature
        (:mod:`fvf.param.features`): the remeshing keeps it and the default field is held
        along it. None: no features.
    features : array_like of int (k, 2), optional
        Feature edges given as vertex pairs of ``mesh`` (either order; each must be an
        edge), added to the sharp edges: the default field is held along them. The input
        is then meshed as it is (never remeshed: the pairs name its own edges).
    return_parameterization : bool
        Deprecated: return ``(V, Q, parameterization)`` instead of the result (typed as
        the result for type checkers); use the result's ``.parameterization``.
    fold_repair_steps : int
        Relaxation steps at most per pass of the untangling of folded quads
        (:func:`fvf.param.quad_folds.untangle_quads`; 0: detect only).
    fallback : {"error", "split"}
        What a component gets when every attempt fails: ``"error"`` (default), the
        :class:`fvf.QuadMeshError`; ``"split"``, quads that follow no field, its triangles
        (midpoint-subdivided to about the quads asked, at least three per triangle) split
        into three quads each (:mod:`fvf.param.split_quads`: on the surface, judged by the
        gate like any attempt; if even they fail it, the error), with a
        :class:`fvf.QuadFallbackWarning`; listed in ``split_components``. A component too
        small for the quads is then split too, not left out.
    **options
        Passed to :func:`fvf.seamless_parameterization` (``scale``, ``rounding_batch``,
        ``scale_iterations``, ``stiffening_iterations``, ``cone_cancel_radius``,
        ``backend``, ``progress``).

    Returns
    -------
    QuadMeshResult
        ``vertices`` float64 (k, 3) on the input surface, ``quads`` int64 (q, 4)
        counter-clockwise about the outward normal, ``vertex_faces``, ``quality``,
        ``parameterizations``; ``V, Q = result`` unpacks the first two.

    Raises
    ------
    QuadMeshError
        No attempt gave a valid mesh (a subclass of :class:`fvf.QuadExtractionError`).
    ParameterizationInputError
        A component has boundary loops, or (``retry=False``) a cone the fit refuses.
    ParameterError
        A bad option (``fold_repair_steps`` negative or not an integer, …).
    ProblemSizeError
        More than :data:`MAX_QUADS_PER_FACE` quads per input triangle, or more than the
        available memory holds at :data:`QUAD_BYTES` per quad (checked before any work).

    Warns
    -----
    SmallComponentWarning
        Components smaller than :data:`MIN_COMPONENT_QUADS` quads that could not be meshed
        were left out (named in the message and in ``dropped_components``).
    DistortedQuadsWarning
        A component's valid results all have corners more than :data:`DISTORTED_CORNERS`
        degrees from square at the 95th percentile (the first is returned).
    QuadFallbackWarning
        With ``fallback="split"``: components whose attempts all failed were split from
        triangles (the message says which, where the attempts failed, and the quads made).
    """
    steps = _check_options(fold_repair_steps, remesh, fallback)
    if features is None:  # (user features name the input's vertices: no weld then)
        mesh = _welded(mesh)
    remesh = "never" if remesh is False or features is not None else remesh
    user_edges = None if features is None else feature_edge_ids(mesh, features)
    h = edge_length_for(mesh, target_faces, edge_length)
    require_order(field, 4, "quad_mesh")
    _check_quad_count(mesh, h, target_faces)
    f = None if field is None else np.asarray(field, dtype=np.float64)
    if f is not None and f.shape != (mesh.n_faces, 3):
        from ..mesh.inputs import as_face_field

        f = as_face_field(mesh, f, "field")
    opts: dict[str, Any] = {
        "steps": steps,
        "remesher": remesher,
        "crease_angle": 180.0 if crease_angle is None else float(crease_angle),
        "features": crease_angle is not None,
        "user_edges": user_edges,
        "seamless": options,
        "align": align,
        "retry": retry,
        "remesh": remesh,
        "fallback": fallback,
    }
    opts["whole"] = mesh
    report = make_progress(options.get("progress"))
    parts = component_parts(mesh)
    made, dropped = _mesh_parts(parts, h, f, opts, report)
    result = join_parts(mesh, made, dropped, h)
    if return_parameterization:
        warnings.warn(
            "quad_mesh(return_parameterization=True) is deprecated: the result carries "
            ".parameterization",
            DeprecationWarning,
            stacklevel=user_stacklevel(),
        )
        if result.parameterizations[0] is None:
            raise ParameterError(
                "quad_mesh(return_parameterization=True): the first component was split from "
                "triangles (fallback='split') and has no parameterization"
            )
        legacy = (result.vertices, result.quads, result.parameterizations[0])
        return cast(QuadMeshResult, legacy)  # the deprecated three values, as before
    return result


def _welded(mesh: TriMesh) -> TriMesh:
    """``mesh`` with its open seams joined (:func:`fvf.mesh.open_seams.weld_open_seams`),
    said with a :class:`~fvf.errors.VerticesWeldedWarning` when anything was joined."""
    welded, merged = weld_open_seams(mesh)
    if merged:
        warnings.warn(
            VerticesWeldedWarning(
                f"quad_mesh: joined {merged} boundary vertices lying at exactly the position "
                "of another (a triangle soup, or a mesh split at its seams): the quads are "
                "made from the joined surface, result.mesh (the faces keep their order)"
            ),
            stacklevel=user_stacklevel(),
        )
    return welded


def _mesh_parts(
    parts: list[Part],
    h: float,
    field: np.ndarray | None,
    opts: dict,
    report: ProgressCallback,
) -> tuple[list, list]:
    made, dropped = [], []
    for part in parts:
        hp = h
        small = part.mesh.total_area < MIN_COMPONENT_QUADS * h * h
        if small:
            hp = float(np.sqrt(part.mesh.total_area / MIN_COMPONENT_QUADS))
        fp = None if field is None else field[part.faces]
        try:
            made.append(_mesh_closures(part, hp, fp, opts, report))
        except QuadMeshError as exc:
            if opts["fallback"] == "split":
                made.append(_split_part(part, hp, exc))
            elif not small or len(parts) == 1:
                raise
            else:
                dropped.append(part)
    if dropped:
        labels = np.array([p.label for p in dropped])
        areas = ", ".join(f"{p.mesh.total_area / (h * h):.2g}" for p in dropped)
        warnings.warn(
            f"components {format_indices(labels)} are too small for quads of edge {h:.3g} "
            f"(areas {areas} target quads) and were left out; ask for more quads to keep them",
            SmallComponentWarning,
            stacklevel=user_stacklevel(),
        )
    if not made:
        raise QuadMeshError("every component is too small for the quad size; ask for more quads")
    return made, dropped


def _split_part(part: Part, h: float, failed: QuadMeshError) -> tuple[Part, tuple]:
    """The component's triangles split into quads
    (:func:`fvf.param.split_quads.split_quad_mesh`), said with a
    :class:`fvf.QuadFallbackWarning`; ``failed`` (the error of its attempts) is raised
    again if even that fails the gate."""
    made = split_quad_mesh(part.mesh, h)
    if not made.validity.valid:  # triangles too thin to split into distinct points
        raise failed
    q = made.quads.shape[0]
    where = "; ".join(f"({', '.join(f'{x:.3g}' for x in p.centre)})" for p in failed.places[:3])
    warnings.warn(
        f"component {part.label} ({part.mesh.n_faces} triangles): no field-aligned quad mesh "
        f"passed the gate in {len(failed.attempts)} attempts"
        + (f" (they failed at {where})" if where else "")
        + f"; as fallback='split' asks, its triangles were split into three quads each: "
        f"{q} valid quads that follow no field (result.split_components)",
        QuadFallbackWarning,
        stacklevel=user_stacklevel(),
    )
    log = [*failed.attempts, f"fallback: its triangles split into three quads each, {q} quads"]
    return part, (
        made.vertices,
        made.quads,
        made.vertex_faces,
        None,
        made.surface,
        made.validity,
        log,
    )


def _mesh_closures(
    part: Part, h: float, field: np.ndarray | None, opts: dict, report: ProgressCallback
) -> tuple[Part, tuple]:
    """The component with the closed surface it was meshed on, and what :func:`_mesh_part`
    made there. A closed component (or without ``retry``, the first of
    :func:`_closures`) gets its attempts; an open one the first attempt on each closure,
    then the other attempts on each, until one gives a valid mesh (a closure whose first
    attempt fails mostly fails its others: a helicoid's domes fail all twelve in 30 s,
    its mirror image succeeds at the first in 0.8 s); else :class:`fvf.QuadMeshError`
    with every attempt, each named by its closure."""
    closures = _closures(part, h)
    if len(closures) == 1 or not opts["retry"]:
        name, close = closures[0]
        closed = _closed(name, close)
        return closed, _mesh_closed(closed, h, field, opts, report)
    failed: list[QuadMeshError] = []
    built: dict[str, Part] = {}
    distorted: tuple | None = None  # the first closure and result valid but distorted
    surfaces: dict[str, dict] = {name: {} for name, _ in closures}
    for phase in ("first", "rest"):
        for name, close in closures:
            try:
                if name not in built:
                    built[name] = _closed(name, close)
                closed = built[name]
                made = _mesh_closed(closed, h, field, opts, report, phase, surfaces[name])
            except QuadMeshError as exc:
                exc.attempts = tuple(f"{name}: {line}" for line in exc.attempts)
                failed.append(exc)
                if name not in built:  # it cannot be built: no other phase
                    closures = [c for c in closures if c[0] != name]
                if isinstance(exc, _OnlyDistorted) and distorted is None:
                    distorted = (built[name], exc.distorted)
                continue
            earlier = [line for exc in failed for line in exc.attempts]
            return closed, (*made[:-1], [*earlier, *(f"{name}: {line}" for line in made[-1])])
    attempts = tuple(line for exc in failed for line in exc.attempts)
    if distorted is not None:  # valid, if distorted: better than none
        closed, (*made, corners) = distorted
        _warn_distorted(part, corners)
        return closed, (*made[:-1], list(attempts))
    spots = [p.centre[None] for exc in failed for p in exc.places for _ in range(p.attempts)]
    places = failure_places(part.mesh, spots, h)
    raise QuadMeshError(
        f"no valid quad mesh of component {part.label} ({part.mesh.n_faces} triangles) "
        f"after {len(attempts)} attempts, closed by domes and by its mirror image:\n  "
        + "\n  ".join(attempts)
        + "\n"
        + describe_places(places, len(attempts), h, part.mesh.total_area)
        + _advice(opts),
        attempts=attempts,
        best=next((exc.best for exc in failed if exc.best is not None), None),
        places=tuple(places),
    )


def _closed(name: str, close: Callable[[], Part]) -> Part:
    """``close()``; an fvf error in it (a chord split into faces too thin for the mesh
    checks) as a :class:`fvf.QuadMeshError` whose one attempt says so, so that the other
    closure is tried."""
    try:
        return close()
    except QuadMeshError:
        raise
    except FvfError as exc:
        line = f"closing it: {type(exc).__name__}: {_first_line(exc)}"
        raise QuadMeshError(f"closing it by {name} failed: {exc}", attempts=(line,)) from exc


def _closures(part: Part, h: float) -> list[tuple[str, Callable[[], Part]]]:
    """How ``part`` is closed for meshing, in order: (name, the closed part when called).
    Itself when closed; else by domes with rings about ``CAP_SPACING * h`` apart
    (:func:`fvf.param.caps.capped`) and by its mirror image
    (:func:`fvf.param.caps.doubled`, made only if tried), the mirror image first where the
    domes would hold more than :data:`DOME_AREA_LIMIT` times its area (a ribbon: a
    boundary loop that winds through space)."""
    if part.mesh.is_closed:
        return [("itself", lambda: part)]
    cap = capped(part.mesh, CAP_SPACING * h)
    domes = ("domes", lambda: dataclasses.replace(part, cap=cap))
    mirror = ("its mirror image", lambda: dataclasses.replace(part, cap=doubled(part.mesh)))
    added = float(cap.mesh.face_areas[cap.is_cap].sum())
    return [mirror, domes] if added > DOME_AREA_LIMIT * part.mesh.total_area else [domes, mirror]


def _closure_name(part: Part) -> str:
    """How the component was closed, as :func:`_closures` names it: "itself" when it is
    closed, "domes" or "its mirror image"."""
    if part.cap is None:
        return "itself"
    return "its mirror image" if part.cap.mirrored else "domes"


def _mesh_closed(
    part: Part,
    h: float,
    field: np.ndarray | None,
    opts: dict,
    report: ProgressCallback,
    phase: str = "all",
    surfaces: dict | None = None,
) -> tuple:
    """:func:`_mesh_part` on the closed surface of ``part`` with its attempts (``phase``
    "first": the first only; "rest": the others), then, unless "first", when they all
    failed at parts narrower than a quad, with more quads (:func:`_finer`)."""
    found = _features(part, part.closed, h, opts)
    if phase != "rest":  # once per closure
        _warn_dense(part, h, opts)
    featured = _featured(found)
    rims = featured and _only_rims(part, found)
    plans = _plans(part, h, opts["align"], opts["retry"], opts["remesh"], featured, rims)
    tried = {"all": plans, "first": plans[:1], "rest": plans[1:]}[phase]
    if not tried:
        raise QuadMeshError("no attempt left", attempts=())
    distorted_ok = phase == "all"  # else the other closure may still do better
    try:
        made = _mesh_part(part, tried, field, opts, report, surfaces, distorted_ok)
    except QuadMeshError as exc:
        if phase == "first" or isinstance(exc, _OnlyDistorted):
            raise
        finer = _finer(part, exc, tried, opts, featured, rims)
        if not finer:
            raise
        try:
            made = _mesh_part(part, finer, field, opts, report, surfaces, distorted_ok)
        except QuadMeshError:
            raise exc from None
        _warn_raised(part, exc, h, finer[0].h)
        return made
    _warn_if_raised(part, made, h)
    return made


def _featured(features: np.ndarray | None) -> bool:
    """Whether :func:`_features` found any."""
    return features is not None and features.size > 0


def _only_rims(part: Part, features: np.ndarray | None) -> bool:
    """Whether the features (edge ids of ``part.closed``) on the open surface itself are
    only its boundary loops (the rims of the domes: a scan with holes; edges on a dome
    do not count)."""
    if part.cap is None or features is None:
        return False
    on_input = (part.closed.edges[features] < part.mesh.n_vertices).all(axis=1)
    return bool(np.isin(features[on_input], part.cap.rim).all())


def _finer(
    part: Part,
    exc: QuadMeshError,
    plans: list[_Plan],
    opts: dict,
    featured: bool,
    rims: bool,
) -> list[_Plan]:
    """The first :data:`FINER_ATTEMPTS` attempts again at the quad edge that resolves the
    narrow parts where every attempt failed (:func:`resolving_edge`), when that edge is
    shorter than every one tried, asks for at most :data:`MAX_RAISE` times the quads and
    the input carries them; else none."""
    h = plans[0].h
    edge = resolving_edge(exc.places, h) if opts["retry"] else None
    if edge is None or edge >= min(p.h for p in plans) or (h / edge) ** 2 > MAX_RAISE:
        return []
    if part.mesh.total_area / edge**2 > MAX_QUADS_PER_FACE * part.mesh.n_faces:
        return []
    asked = (opts["align"], opts["retry"], opts["remesh"])
    return _plans(part, edge, *asked, featured, rims)[:FINER_ATTEMPTS]


def _warn_if_raised(part: Part, made: tuple, h: float) -> None:
    """A :class:`~fvf.errors.QuadCountRaisedWarning` when the valid attempt made more quads
    than asked: sized by curvature with more than :data:`SIZED_WARN` times the quads, or
    of one size at a shorter edge than ``h`` (the retries at 1.5× and 2.25× the quads)."""
    Q, param = made[1], made[3]
    ratio = Q.shape[0] * h * h / part.mesh.total_area
    if param.info["log_scale"] is not None and ratio > SIZED_WARN:
        why = (
            "with quads sized by curvature: the attempts of one size failed, and where the "
            "surface's radius of curvature is below a quad edge the quads are about that radius"
        )
    elif param.edge_length < h * (1.0 - 1e-9):
        why = (
            f"with quads of edge {param.edge_length:.3g}: the attempts at the edge asked "
            "failed (features closer than a quad edge, cones that landed on one grid point)"
        )
    else:
        return
    warnings.warn(
        QuadCountRaisedWarning(
            f"quad_mesh: component {part.label} was meshed {why}; {Q.shape[0]} quads, "
            f"{ratio:.2g} times the quads asked (edge {h:.3g})"
        ),
        stacklevel=user_stacklevel(),
    )


def _warn_dense(part: Part, h: float, opts: dict) -> None:
    """:class:`fvf.DenseFeaturesWarning` when the component's sharp edges were left out
    as denser than the quads (:func:`_own_features`)."""
    density = _density(part, h, opts)
    if density is None:
        return
    warnings.warn(
        f"component {part.label}: its sharp edges are {density:.3g} times as long as the "
        f"area over the quad edge ({h:.3g}): longer than all edges of the quads (about "
        f"{DENSE_FEATURES:g} times; a thread, a knurl), so they are not followed and the "
        "surface is meshed as smooth; about "
        f"{(density / DENSE_FEATURES) ** 2:.3g} times the quads would follow them, or pass "
        "the edges to keep as features=",
        DenseFeaturesWarning,
        stacklevel=user_stacklevel(),
    )


def _warn_distorted(part: Part, corners: float) -> None:
    warnings.warn(
        f"component {part.label}: the quads are valid but distorted (corner angles "
        f"{corners:.0f}° from 90° at the 95th percentile; no attempt gave undistorted "
        "ones). Try more quads (a coarse input's cones crowd few quads), or remeshing "
        "first (remesh=True, fvf quad --remesh always) so that the input's long "
        "triangles do not shape them",
        DistortedQuadsWarning,
        stacklevel=user_stacklevel(),
    )


def _warn_raised(part: Part, exc: QuadMeshError, h: float, edge: float) -> None:
    where = ", ".join("(" + ", ".join(f"{x:.4g}" for x in p.centre) + ")" for p in exc.places)
    warnings.warn(
        QuadCountRaisedWarning(
            f"quad_mesh: component {part.label} was meshed with quads of edge {edge:.3g}, "
            f"{(h / edge) ** 2:.2g} times the quads asked (edge {h:.3g}): every attempt at "
            f"the size asked failed where the surface is thinner than a quad edge, at "
            f"{where}; ask for fewer quads only after thickening or cutting off those parts"
        ),
        stacklevel=user_stacklevel(),
    )


def _check_options(fold_repair_steps: object, remesh: object, fallback: object) -> int:
    if (
        isinstance(fold_repair_steps, bool)
        or not isinstance(fold_repair_steps, int | np.integer)
        or fold_repair_steps < 0
    ):
        raise ParameterError(
            f"fold_repair_steps must be a non-negative integer; got {fold_repair_steps!r}"
        )
    if remesh not in ("auto", True, "never", False):
        raise ParameterError(f"remesh must be 'auto', True or 'never'; got {remesh!r}")
    if fallback not in FALLBACKS:
        raise ParameterError(f"fallback must be one of {FALLBACKS}; got {fallback!r}")
    return int(fold_repair_steps)
