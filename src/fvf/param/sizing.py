r"""Quad sizes that follow the surface: a conformal scale from the curvature.

Uniform quads of edge $h$ cannot follow a part whose radius of curvature is below $h$ (a
finger, a thin tube, a fillet): a quad spans a half turn of the surface there and its
parameterization flips. Quads of edge $h e^{-s}$, $s \ge 0$ a function on the surface,
are quads of edge $h$ in the conformally scaled metric $e^{2s} g$. A seamless
parameterization for that metric needs

* a cross field smooth in $e^{2s} g$: the field is designed on the connection whose
  holonomy is the curvature of $e^{2s} g$, $\tilde K + L s$
  (:mod:`fvf.design.holonomy`, ``log_scale``), which gives it the cones that a change of
  quad size needs;
* a frame of length $e^{s} / h$: the per-face scales $(a, b)$ of
  :mod:`fvf.param.frame_field` multiplied by $e^{s}$.

:func:`curvature_log_scale` chooses $s$ so that a quad edge is at most
:data:`EDGE_PER_RADIUS` radii of curvature, $s = \log \max(1, h\kappa /
\text{EDGE\_PER_RADIUS})$ with $\kappa = \max(|\kappa_1|, |\kappa_2|)$ per face, capped at
$\log$ :data:`MAX_REFINEMENT` and smoothed by one implicit heat step over $h$,
$(M + h^2 L)\, \tilde s = M s$, so that it changes over a quad edge, not a triangle. Where
the surface is flatter than $1/h$, $s = 0$ and the quads keep the edge asked for; the
total number of quads grows by $\int e^{2s} dA / \int dA$.
"""

from __future__ import annotations

import numpy as np

from ..calculus import face_to_vertex, vertex_areas
from ..design.holonomy import heat_step
from ..mesh.curvature import principal_curvatures
from ..mesh.trimesh import TriMesh

__all__ = ["EDGE_PER_RADIUS", "MAX_REFINEMENT", "curvature_log_scale", "refinement"]

#: A quad edge is at most this many radii of curvature (a tube gets about 2π of them
#: around).
EDGE_PER_RADIUS = 1.0
#: Quads are at most this many times shorter than asked.
MAX_REFINEMENT = 16.0


def curvature_log_scale(mesh: TriMesh, h: float) -> np.ndarray:
    r"""The conformal scale $\tilde s$ (module docstring), float64 (n,), one per vertex.

    Parameters
    ----------
    mesh : TriMesh
        Closed (the heat step and the designs that use $\tilde s$ need no boundary
        condition).
    h : float
        The quad edge asked for, > 0.

    Returns
    -------
    float64 (n,)
        $\tilde s \ge 0$; quads of edge $h e^{-\tilde s}$ follow the surface's curvature.
    """
    pc = principal_curvatures(mesh)
    kappa = np.maximum(np.abs(pc.k1), np.abs(pc.k2))
    per_face = np.log(np.clip(h * kappa / EDGE_PER_RADIUS, 1.0, MAX_REFINEMENT))
    s = face_to_vertex(mesh) @ per_face  # area-weighted average around each vertex
    return np.maximum(heat_step(mesh, h, vertex_areas(mesh) * s), 0.0)


def refinement(mesh: TriMesh, log_scale: np.ndarray) -> float:
    r"""How many times the quads of a uniform size the scale asks for,
    $\sum_v M_v e^{2 s_v} / \sum_v M_v$ (float)."""
    M = vertex_areas(mesh)
    return float((M * np.exp(2.0 * log_scale)).sum() / M.sum())
