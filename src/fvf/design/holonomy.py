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

**A conformal scale.** Quads of varying size are quads of one size in a conformally
scaled metric $\tilde g = e^{2s} g$ ($s$ a function on the vertices): lengths grow by
$e^{s}$, so where $s > 0$ the quads of one $\tilde g$-length are $e^{s}$ times smaller
on the surface. The curvature of $\tilde g$ is $\tilde K\, dA_{\tilde g} = (K - \Delta s)\,
dA$, integrated over the vertex cells $K_v + (L s)_v$ (the cotangent stiffness $L$ is
$-\int \Delta$ in the weak form). With ``log_scale=s`` the target holonomy is
$\tilde K + L s$: a field parallel for that connection is smooth in $\tilde g$, and it
gets the cones that a change of quad size needs (a tube whose quads are smaller than its
neighbourhood's has fewer quads around it at one end than the other: cones of index
$+1/4$ on one side of the change and $-1/4$ on the other, where $-\Delta s$ gathers a
quarter turn). $L$ has zero row sums, so the total stays $2\pi\chi$.
"""

from __future__ import annotations

import hashlib

import numpy as np
import scipy.sparse as sp

from ..calculus import stiffness, vertex_areas
from ..errors import ParameterError, format_indices
from ..mesh.geometry import angle_defects
from ..mesh.trimesh import TriMesh
from ..numerics.cholesky import factor_hermitian

__all__ = ["smoothed_angle_defects", "holonomy_rotations", "heat_step"]


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
    return vertex_areas(mesh) * heat_step(mesh, ell, angle_defects(mesh))


def heat_step(mesh: TriMesh, length: float, rhs: np.ndarray) -> np.ndarray:
    r"""One implicit heat step over ``length``: $(M + \ell^2 L)^{-1} b$, float64 (n,).

    $M$ the barycentric vertex areas, $L$ the cotangent stiffness; ``rhs`` $b$ (n,) is
    integrated (a vertex function $f$ smoothed is ``heat_step(mesh, ell, M * f)``).
    """
    heat = sp.csr_array(sp.diags_array(vertex_areas(mesh)) + length**2 * stiffness(mesh))
    return factor_hermitian(heat, "auto", "few").solve(rhs)


def log_scale_key(log_scale: np.ndarray | None) -> str:
    """A short digest of a vertex log scale for cache keys ("" for None)."""
    if log_scale is None:
        return ""
    data = np.ascontiguousarray(log_scale, dtype=np.float64).tobytes()
    return ":scaled " + hashlib.blake2b(data, digest_size=8).hexdigest()


def as_log_scale(mesh: TriMesh, log_scale: object) -> np.ndarray | None:
    """``log_scale`` checked: None, or finite float64 (n,) (:class:`fvf.ParameterError`)."""
    if log_scale is None:
        return None
    s = np.asarray(log_scale, dtype=np.float64)
    if s.shape != (mesh.n_vertices,) or not np.isfinite(s).all():
        raise ParameterError(
            f"log_scale must be a finite float array of shape ({mesh.n_vertices},), one "
            f"value per vertex; got shape {s.shape}"
        )
    return s


def holonomy_rotations(
    mesh: TriMesh, length: float, log_scale: np.ndarray | None = None
) -> np.ndarray:
    r"""Angles $x_e$ added to the transports so that the holonomy is $\tilde K$ (module
    docstring).

    Parameters
    ----------
    mesh : TriMesh
        Closed.
    length : float
        Smoothing length $\ell > 0$ (:func:`smoothed_angle_defects`).
    log_scale : float64 (n,), optional
        A conformal scale $s$ per vertex: the target holonomy is $\tilde K + L s$, that of
        the metric $e^{2s} g$ (module docstring). Default: $s = 0$.

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
    s = as_log_scale(mesh, log_scale)
    return mesh.cached(
        f"holonomy_rotations:{ell!r}{log_scale_key(s)}", lambda: _rotations_for(mesh, ell, s)
    )


def _rotations_for(mesh: TriMesh, length: float, log_scale: np.ndarray | None) -> np.ndarray:
    """The uncached :func:`holonomy_rotations`, made read-only."""
    target = smoothed_angle_defects(mesh, length)
    if log_scale is not None:
        target = target + stiffness(mesh) @ log_scale
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
