r"""A face connection whose holonomy is the smoothed angle defect.

The discrete Levi-Civita connection of :mod:`fvf.design.connection` has holonomy $K_v$
(the angle defect) around each vertex $v$. On scans and remeshed surfaces much of the
Gaussian curvature sits on single vertices — spikes, pinches, valence-4 vertices with
$|K_v|$ up to $\pi$ — and the index of a cross field that is smooth around such a vertex
is $K_v / 2\pi$ rounded to a quarter (:func:`fvf.singularities`), so every vertex with
$|K_v| > \pi/4$ carries a cone, whatever the field's design asks for.

Spreading that curvature over a length $\ell$ frees the cones. The angle defect is
smoothed by one implicit heat step,

.. math::

    (M + \ell^2 L)\, u = K, \qquad \tilde K = M u ,

($M$ the barycentric vertex areas, $L$ the cotangent stiffness), which keeps the total
$\sum_v \tilde K_v = \sum_v K_v = 2\pi\chi$ on each component. The transport of each
interior edge $e$ (oriented from ``edges[e, 0]`` to ``edges[e, 1]``) is turned by an
angle $x_e$, $r_e \mapsto r_e e^{i x_e}$, chosen of least norm with

.. math::

    G^\top x = K - \tilde K ,

$G$ the signed edge–vertex incidence ($+1$ at ``edges[e, 1]``, $-1$ at ``edges[e, 0]``):
$x = G\varphi$ with $G^\top G \varphi = K - \tilde K$ (the graph Laplacian, one vertex
per component held at 0). The holonomy of the turned connection around $v$ is then
$\tilde K_v$, the same idea as the trivial connections of Crane, Desbrun & Schröder (2010),
here with a smooth target curvature instead of chosen cones. A field that is parallel for
the turned connection differs from a parallel one by $x_e$ across each edge, so as long as
$|x_e| < \pi/(2N)$ the indices :func:`fvf.singularities` measures with the true connection
are those of the turned one: cones where $\tilde K$ accumulates a quarter turn, not at
each spike. A vertex whose defect is too large for its few edges ($|K_v| / \deg v$ beyond
about $\pi/4$) keeps its cone.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from ..calculus import stiffness, vertex_areas
from ..errors import ParameterError, format_indices
from ..mesh.geometry import angle_defects
from ..mesh.trimesh import TriMesh
from ..numerics.cholesky import factor_hermitian

__all__ = ["smoothed_angle_defects", "holonomy_rotations"]


def smoothing_length(length: float, name: str = "curvature_smoothing") -> float:
    """``length`` as a float > 0, else :class:`fvf.ParameterError` naming ``name``."""
    try:
        value = float(length)
    except (TypeError, ValueError):
        value = float("nan")
    if not np.isfinite(value) or value <= 0.0:
        raise ParameterError(f"{name} must be a length > 0; got {length!r}")
    return value


def _require_closed(mesh: TriMesh) -> None:
    if not mesh.is_closed:
        raise ParameterError(
            f"curvature smoothing needs a closed mesh; edges "
            f"{format_indices(mesh.boundary_edges)} are on a boundary. Fix: fill the holes, "
            "or design without curvature_smoothing"
        )


def smoothed_angle_defects(mesh: TriMesh, length: float) -> np.ndarray:
    r"""The angle defect smoothed over ``length``: $\tilde K = M (M + \ell^2 L)^{-1} K$.

    Parameters
    ----------
    mesh : TriMesh
        Closed.
    length : float
        Smoothing length $\ell > 0$ in the mesh's units (about the size of the features
        that should carry no cone, e.g. a target quad edge).

    Returns
    -------
    float64 (n,)
        Integrated curvature per vertex; sums to $2\pi\chi$ on each component, like $K$.
    """
    ell = smoothing_length(length)
    _require_closed(mesh)
    K = angle_defects(mesh)
    A = vertex_areas(mesh)
    heat = sp.csr_array(sp.diags_array(A) + ell**2 * stiffness(mesh))
    u = factor_hermitian(heat, "auto", "few").solve(K)
    return A * u


def holonomy_rotations(mesh: TriMesh, length: float) -> np.ndarray:
    r"""Angles $x_e$ added to the transports so that the holonomy is $\tilde K$ (module
    docstring).

    Parameters
    ----------
    mesh : TriMesh
        Closed.
    length : float
        Smoothing length $\ell > 0$ (:func:`smoothed_angle_defects`).

    Returns
    -------
    float64 (E,), read-only
        One angle per edge (``mesh.edges`` order), least norm with
        $G^\top x = K - \tilde K$; multiply the transport of the pair across edge e
        (:func:`fvf.design.connection.connection_pairs`, ``"knoppel"``) by
        $e^{i x_e}$. Cached on the mesh per length: the design of a field and the
        measurement of its cones (:mod:`fvf.param`) share one computation.
    """
    ell = smoothing_length(length)
    return mesh.cached(f"holonomy_rotations:{ell!r}", lambda: _rotations_for(mesh, ell))


def _rotations_for(mesh: TriMesh, length: float) -> np.ndarray:
    """The uncached :func:`holonomy_rotations`, made read-only."""
    target = smoothed_angle_defects(mesh, length)
    K = angle_defects(mesh)
    E = mesh.edges
    n, ne = mesh.n_vertices, E.shape[0]
    rows = np.concatenate([np.arange(ne), np.arange(ne)])
    G = sp.csr_array(
        (np.concatenate([np.ones(ne), -np.ones(ne)]), (rows, np.concatenate([E[:, 1], E[:, 0]]))),
        shape=(ne, n),
    )
    keep = np.ones(n, dtype=bool)
    keep[np.unique(mesh.vertex_components, return_index=True)[1]] = False  # one per component
    Gk = G[:, np.flatnonzero(keep)]
    phi = np.zeros(n)
    phi[keep] = factor_hermitian(sp.csr_array(Gk.T @ Gk), "auto", "few").solve((K - target)[keep])
    x = G @ phi
    x.setflags(write=False)
    return x
