"""The chapter's example scenes: Spot, the fields of Fig. 12 and the compressible case.

Ready-made inputs for the examples, the demo, the tests and the benchmarks. Spot itself is
:func:`fvf.mesh.builtin.spot` (re-exported here); the scenes need the calculus, so they sit
above it, beside :mod:`fvf.chapter` (docs/architecture.md).
"""

from __future__ import annotations

import numpy as np

from .calculus import gradient
from .mesh.builtin import spot, spot_path
from .mesh.convert import takes_mesh
from .mesh.trimesh import TriMesh

__all__ = ["spot", "spot_path", "fig12_fields", "compressible_case"]


@takes_mesh
def fig12_fields(
    mesh: TriMesh, theta: float = 2.4, width: float = 0.9
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The two fields and the flow of the chapter's Fig. 12 (interpolation along a flow).

    u0 and u1 are the gradients of Gaussian bumps exp(−|x − a|²/width²) centred at
    a0 = R_z(θ/2) e_x and a1 = R_z(−θ/2) e_x; v = θ e_z × x (projected per face) carries a0
    to a1 in unit time. On a unit sphere their average has two maxima and a saddle between
    the bumps, while the interpolant of eq. (68) keeps one maximum moving along the equator.

    Parameters
    ----------
    mesh : TriMesh
        Best a unit sphere centred at the origin (e.g. ``fvf.icosphere(4)``).
    theta : float
        Angle between the bumps (radians).
    width : float
        Width of the bumps.

    Returns
    -------
    u0, u1, v : float64 (m, 3)
        Per-face fields.
    """
    X = mesh.vertices
    a0 = np.array([np.cos(theta / 2), np.sin(theta / 2), 0.0])
    a1 = np.array([np.cos(theta / 2), -np.sin(theta / 2), 0.0])
    u0 = gradient(mesh, np.exp(-((X - a0) ** 2).sum(1) / width**2))
    u1 = gradient(mesh, np.exp(-((X - a1) ** 2).sum(1) / width**2))
    v = theta * mesh.project_tangent(np.cross([0.0, 0.0, 1.0], mesh.face_centroids))
    return u0, u1, v


@takes_mesh
def compressible_case(mesh: TriMesh) -> tuple[TriMesh, np.ndarray, np.ndarray]:
    """The lion case of docs/chapter.md ("Facts we measured") on any mesh.

    The mesh is centred and scaled to unit radius; v = grad x with unit L2 norm
    (Σ_f |v_f|² area_f = 1); f0 = sin 3y + z. On lion-00 the chapter's flow of f0 along v
    reaches ±1e17 by t = 0.1; the tests and ``benchmarks/bench_flows.py`` run it on every
    mesh.

    Parameters
    ----------
    mesh : TriMesh

    Returns
    -------
    mesh : TriMesh
        The centred, scaled copy.
    v : ndarray float64 (m, 3)
    f0 : ndarray float64 (n,)
    """
    X = mesh.vertices - mesh.vertices.mean(0)
    X = X / np.linalg.norm(X, axis=1).max()
    scaled = TriMesh(X, mesh.faces)
    v = gradient(scaled, X[:, 0])
    v = v / np.sqrt((scaled.face_areas * (v * v).sum(1)).sum())
    return scaled, v, np.sin(3 * X[:, 1]) + X[:, 2]
