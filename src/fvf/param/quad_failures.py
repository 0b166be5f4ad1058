r"""Where the attempts of :func:`fvf.quad_mesh` failed, and how thick the surface is there.

Each failed attempt leaves points: the centroids of its flipped uv triangles, the centres
of its folded quads, or the cones it refused. Points of all attempts closer than
:data:`PLACE_RADIUS` quad edges are one **place**; a place where most attempts failed
comes first. At each failure point p, with n the input's normal at the closest surface
point, the **thickness** is the distance to the nearest sample q of the surface within one
quad edge h that lies behind it and faces the other way,

$$ t(p) = \min \{\, |q - p| : (q - p)\cdot n < 0,\ n_q \cdot n < -\tfrac12 \,\} $$

(the diameter of a finger, the height of a thin plate; :math:`\infty` when there is
none: a sharp edge of a thick part is not thin), and a place's thickness is the lower
quartile over its points (:data:`QUANTILE`). A place thinner than :data:`NARROW` quad
edges (a finger, a spike, a knife edge, a thin wall) is not resolved by any retry at
about that size: the message says so and what to do, and :func:`fvf.quad_mesh` tries
once more at the quad edge :math:`t` (:func:`resolving_edge`) when that asks for at most
:data:`fvf.param.quadmesh.MAX_RAISE` times the quads.
"""

from __future__ import annotations

from dataclasses import dataclass
from itertools import chain

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from ..mesh.trimesh import TriMesh
from ..numerics.summary import html_repr, short_repr
from .quad_folds import closest_surface_points, surface_sample_tree

__all__ = ["Place", "failure_places", "thickness", "describe_places", "resolving_edge"]

#: Failure points closer than this many quad edges belong to one place.
PLACE_RADIUS = 2.0
#: At most this many places are named in a message.
MAX_PLACES = 4
#: A place's thickness is this quantile of its points' (a place where a finger joins a
#: palm has thin and thick points).
QUANTILE = 0.25
#: A place is thinner than the quads when its thickness is below this many h (a place
#: about one quad edge thick fails for other reasons: on 27 OpenSCAD parts, those 0.8 to
#: 1 quad edge thick met at 1.5 times the quads, not at their thickness).
NARROW = 0.75


@dataclass(frozen=True)
class Place:
    """One place where attempts failed.

    Attributes
    ----------
    centre : float64 (3,)
        Its failure point nearest to their mean (a point of the surface: the mean of a
        place strung along a thin wall's rim can lie in the air).
    attempts : int
        How many attempts failed there.
    thickness : float
        The surface's thickness there (module docstring); ``inf`` when it is thicker
        than a quad edge.
    """

    __repr__ = short_repr  # arrays by dtype and shape
    _repr_html_ = html_repr  # a table in Jupyter

    centre: np.ndarray
    attempts: int
    thickness: float


def failure_places(mesh: TriMesh, spots: list[np.ndarray], h: float) -> list[Place]:
    """The places where attempts failed, most attempts first.

    Parameters
    ----------
    mesh : TriMesh
        The component meshed.
    spots : list of float64 (k_i, 3)
        Failure points of each attempt (empty arrays for attempts that left none).
    h : float
        Target quad edge length.
    """
    pts = [np.asarray(s, np.float64).reshape(-1, 3) for s in spots]
    if sum(len(p) for p in pts) == 0:
        return []
    X = np.concatenate(pts)
    attempt = np.repeat(np.arange(len(pts)), [len(p) for p in pts])
    pairs = cKDTree(X).query_pairs(PLACE_RADIUS * h, output_type="ndarray")
    link = sp.coo_array((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(len(X),) * 2)
    n, label = connected_components(link, directed=False)
    count = np.bincount(label, minlength=n)
    mean = np.stack([np.bincount(label, X[:, k], n) for k in range(3)], axis=1) / count[:, None]
    first = np.lexsort((np.linalg.norm(X - mean[label], axis=1), label))
    centre = X[first[np.searchsorted(label[first], np.arange(n))]]  # nearest member
    seen = np.unique(np.stack([label, attempt], axis=1), axis=0)
    tries = np.bincount(seen[:, 0], minlength=n)
    order = np.lexsort((-count, -tries))[:MAX_PLACES]
    thick = thickness(mesh, X, h)
    return [
        Place(
            centre[i],
            int(tries[i]),
            float(np.quantile(thick[label == i], QUANTILE, method="lower")),
        )
        for i in order
    ]


def thickness(mesh: TriMesh, points: np.ndarray, h: float) -> np.ndarray:
    """t(p) of the module docstring at each point, float64 (k,) (``inf``: thicker than h)."""
    face, p = closest_surface_points(mesh, points)
    n = mesh.face_normals[face]
    samples, owner = surface_sample_tree(mesh)
    near = samples.query_ball_point(p, h)
    counts = np.fromiter((len(x) for x in near), np.int64, len(near))
    rows = np.repeat(np.arange(len(p)), counts)
    cols = np.fromiter(chain.from_iterable(near), np.int64, int(counts.sum()))
    d = samples.data[cols] - p[rows]
    behind = np.einsum("kd,kd->k", d, n[rows]) < 0
    facing = np.einsum("kd,kd->k", mesh.face_normals[owner[cols]], n[rows]) < -0.5
    out = np.full(len(p), np.inf)
    np.minimum.at(out, rows[behind & facing], np.linalg.norm(d[behind & facing], axis=1))
    return out


def describe_places(places: list[Place], n_attempts: int, h: float, area: float) -> str:
    """The message's lines on ``places`` ('' when there are none)."""
    if not places:
        return ""
    digits = max(3, int(np.ceil(-np.log10(h))) + 2)
    lines = []
    for p in places:
        thick = f", {p.thickness / h:.2g} quad edges thick" if np.isfinite(p.thickness) else ""
        at = ", ".join(f"{x:.{digits}g}" for x in p.centre)
        lines.append(f"Where: ({at}), {p.attempts} of {n_attempts} attempts{thick}")
    edge = resolving_edge(places, h)
    if edge is not None:
        lines.append(
            f"The surface is thinner than a quad edge there (a finger, a spike, a knife "
            f"edge: {edge:.3g} against the quad edge {h:.3g}). Uniform quads need an edge "
            f"of about {edge:.3g} there (about {area / edge**2:.3g} quads; at least that: "
            "finer quads can fail at thinner parts elsewhere, a scan's toes after its "
            "fingers); or thicken, smooth or cut off those parts first (a scan's spikes: "
            "fvf.flatten_spikes, fvf repair --despike)."
        )
    return "\n".join(lines) + "\n"


def resolving_edge(places: list[Place] | tuple[Place, ...], h: float) -> float | None:
    """The quad edge t that resolves the thinnest place thinner than :data:`NARROW` h, or
    None when no place is."""
    thin = [p.thickness for p in places if p.thickness < NARROW * h]
    return min(thin) if thin else None
