"""Streamlines of a per-face field, traced exactly from face to face.

A per-face field is constant on each face, so inside face t its integral curve is a
straight segment along v_t. The tracer walks that segment to the face's boundary
(where a barycentric coordinate reaches 0), steps into the face across that edge and
goes on along the next face's vector, until the requested arc length is used up, the
curve reaches the mesh boundary, a zero vector, or an edge where the two faces' vectors
point at each other (a sink line).
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from ..calculus import hat_gradients
from ..errors import FvfError
from ..mesh.convert import takes_mesh
from ..mesh.inputs import as_face_field
from ..mesh.trimesh import TriMesh
from .arrows import spread_faces

__all__ = ["streamlines", "trace"]


@takes_mesh
def trace(
    mesh: TriMesh,
    field: npt.ArrayLike,
    faces: npt.ArrayLike,
    points: npt.ArrayLike,
    length: float,
    max_crossings: int | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Trace integral curves of the unit field v/|v| forward, all seeds at once.

    Parameters
    ----------
    mesh : TriMesh
    field : array_like (m, 3)
        Tangent vector per face; a negated field traces backward.
    faces : array_like of int (k,)
        Face containing each seed.
    points : array_like (k, 3)
        Seed points, in (or on the boundary of) their faces.
    length : float
        Arc length to trace, in mesh units.
    max_crossings : int, optional
        Most faces a curve may cross (default: 50 times ``length`` over the mean edge
        length, plus 100).

    Returns
    -------
    positions : ndarray float64 (s + 1, k, 3)
        Point of each curve after each step (repeated once a curve has stopped).
    step_faces : ndarray int64 (s, k)
        Face that step j of each curve crossed (-1 once stopped).
    alive_steps : ndarray int64 (k,)
        Number of steps each curve made.
    """
    v = as_face_field(mesh, field, "field")
    speed = np.sqrt((v * v).sum(1))
    top = speed.max() if speed.size else 0.0
    unit = np.divide(v, speed[:, None], out=np.zeros_like(v), where=speed[:, None] > 1e-12 * top)
    G = hat_gradients(mesh)  # (m, 3, 3): gradient of corner i's hat function on face t
    X, F, adj = mesh.vertices, mesh.faces, mesh.face_adjacency
    f = np.asarray(faces, dtype=np.int64).copy()
    p = np.asarray(points, dtype=float).copy()
    k = f.size
    remaining = np.full(k, float(length))
    alive = unit[f].any(1) & (remaining > 0)
    previous = np.full(k, -1)
    tiny = 1e-9 * mesh.mean_edge_length
    if max_crossings is None:
        max_crossings = int(50 * length / mesh.mean_edge_length) + 100
    positions, step_faces = [p.copy()], []
    steps = np.zeros(k, dtype=np.int64)
    for _ in range(max_crossings):
        if not alive.any():
            break
        idx = np.flatnonzero(alive)
        ft, d, g = f[idx], unit[f[idx]], G[f[idx]]
        # barycentric coordinates b_i = <p - x_{i+1}, grad phi_i> and their rates along d
        nxt = X[F[ft][:, [1, 2, 0]]]  # (a, 3, 3): vertex after corner i
        b = np.clip(np.einsum("aij,aij->ai", g, p[idx, None, :] - nxt), 0.0, 1.0)
        rate = np.einsum("aij,aj->ai", g, d)
        with np.errstate(divide="ignore", invalid="ignore"):
            s = np.where(rate < 0, b / -rate, np.inf)
        corner = s.argmin(1)
        step = s[np.arange(idx.size), corner]
        step = np.minimum(step, remaining[idx])
        p[idx] += step[:, None] * d
        remaining[idx] -= step
        sf = np.full(k, -1)
        sf[idx] = ft
        step_faces.append(sf)
        steps[idx] += 1
        positions.append(p.copy())
        across = adj[ft, corner]
        done = (remaining[idx] <= tiny) | (across < 0)
        # a zero-length step back into the face just left: the vectors meet at the edge
        done |= (step <= tiny) & (across == previous[idx])
        done |= ~unit[np.maximum(across, 0)].any(1)
        previous[idx] = ft
        f[idx] = np.where(done, ft, across)
        alive[idx[done]] = False
    return np.stack(positions), np.array(step_faces).reshape(-1, k), steps


@takes_mesh
def streamlines(
    mesh: TriMesh,
    field: npt.ArrayLike,
    seeds: int | npt.ArrayLike = 150,
    *,
    length: float | None = None,
    direction: str = "both",
    return_faces: bool = False,
) -> list[np.ndarray] | tuple[list[np.ndarray], list[np.ndarray]]:
    """Streamlines of a per-face field, traced face to face from seed faces.

    Parameters
    ----------
    mesh : TriMesh
    field : array_like (m, 3)
        Tangent vector per face. Curves follow the direction v/|v| (arc-length
        parametrised); zero vectors stop them.
    seeds : int or array_like of int (k,)
        The number of seeds, spread evenly over the surface
        (:func:`~fvf.viz.arrows.spread_faces`), or the seed faces themselves. Each curve
        starts at its seed face's centroid.
    length : float, optional
        Arc length traced in each direction (default: 12 mean edge lengths).
    direction : {"both", "forward", "backward"}
        Trace along v, against it, or both (joined at the seed).
    return_faces : bool
        Also return, per curve, the face of each segment.

    Returns
    -------
    list of ndarray float64 (p_i, 3)
        One polyline per seed (curves that could not move have one point), ordered
        along v.
    list of ndarray int64 (p_i - 1,), only with ``return_faces``
        Face that segment j of curve i lies in; the segment is parallel to v there.
    """
    if direction not in ("both", "forward", "backward"):
        raise FvfError(f"direction must be 'both', 'forward' or 'backward'; got {direction!r}")
    v = as_face_field(mesh, field, "field")
    seeds = np.asarray(seeds)
    if seeds.ndim == 0:
        seed_faces = spread_faces(mesh, int(seeds))
    else:
        seed_faces = seeds.astype(np.int64).ravel()
        if seed_faces.size and (seed_faces.min() < 0 or seed_faces.max() >= mesh.n_faces):
            raise FvfError(f"seed faces must be in [0, {mesh.n_faces})")
    if length is None:
        length = 12.0 * mesh.mean_edge_length
    start = mesh.face_centroids[seed_faces]
    parts: list[tuple[np.ndarray, np.ndarray, np.ndarray] | None] = []
    for sign in (1.0, -1.0):
        if (sign > 0 and direction == "backward") or (sign < 0 and direction == "forward"):
            parts.append(None)
            continue
        parts.append(trace(mesh, sign * v, seed_faces, start, length))
    lines, line_faces = [], []
    for i in range(seed_faces.size):
        pts, fcs = [start[i][None]], [np.empty(0, dtype=np.int64)]
        if parts[1] is not None:
            P, S, n = parts[1]
            pts.insert(0, P[1 : n[i] + 1, i][::-1])
            fcs.insert(0, S[: n[i], i][::-1])
        if parts[0] is not None:
            P, S, n = parts[0]
            pts.append(P[1 : n[i] + 1, i])
            fcs.append(S[: n[i], i])
        lines.append(np.concatenate(pts))
        line_faces.append(np.concatenate(fcs))
    return (lines, line_faces) if return_faces else lines
