"""Where the camera looks from: a :class:`View`, the up axis, and the camera frame.

Both backends use the same frame, so a picture made by polyscope and one made by
matplotlib show the mesh from the same side.

The up axis (``View(up="auto")``, the default) is y, the OBJ convention, unless the mesh
clearly stands on another side (:func:`detect_up_axis`): scans such as Nefertiti are
stored z-up, while the Stanford models, Spot and the TOSCA animals are y-up; a
mirror-symmetric shape (a body, an animal) stored x-up is found x-up.
Any axis, either way round, can be made up: ``View(up="-y")`` shows a y-up
picture upside down, ``up="x"`` stands an x-up file upright.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import TypeGuard

import numpy as np

from ..errors import FvfError, ParameterError

__all__ = [
    "UP_AXES",
    "View",
    "aim",
    "as_view",
    "as_views",
    "camera_frame",
    "detect_up_axis",
    "mirror_axis",
    "resolve_up",
    "two_sides",
]

_AXES = {"x": 0, "y": 1, "z": 2}
#: The axes that can point up in a picture: x, y, z or their opposites.
UP_AXES = ("x", "y", "z", "-x", "-y", "-z")

#: Support band: points within this fraction of the height above the lowest point.
SUPPORT_BAND = 0.03
#: z is chosen over y only when its stability is larger by this much (fractions of the
#: footprint's size).
UP_MARGIN = 0.05


@dataclass(frozen=True)
class View:
    """A camera direction around the mesh.

    Attributes
    ----------
    azimuth : float or None
        Degrees about the up axis, from the "front" axis (the axis after ``up`` in x, y, z
        order: +z for ``up="y"`` or ``"-y"``, +x for ``up="z"``) toward the "right" axis
        (+x for ``up="y"``, −x for ``up="-y"``). None picks the side of the mesh's
        bounding box with the larger silhouette and turns 30° from it (a three-quarter
        view).
    elevation : float
        Degrees above the horizontal plane.
    up : {"auto", "x", "y", "z", "-x", "-y", "-z"}
        The mesh axis that points up in the picture (``"-y"``: −y up, the ``"y"``
        picture turned upside down). ``"auto"`` (default): :func:`detect_up_axis`.
    zoom : float
        > 1 fills more of the picture (1 fits the whole mesh with a small margin).
    turn : float
        Degrees added to the azimuth, automatic or given (:func:`two_sides` uses 180).
    """

    azimuth: float | None = None
    elevation: float = 20.0
    up: str = "auto"
    zoom: float = 1.0
    turn: float = 0.0


def as_view(view: View | tuple | dict | None) -> View:
    """A :class:`View` from None, a View, ``(azimuth, elevation[, up[, zoom]])`` or a dict."""
    if view is None:
        return View()
    if isinstance(view, View):
        out = view
    elif isinstance(view, dict):
        out = View(**view)
    elif isinstance(view, (tuple, list)):
        out = View(*view)
    else:
        raise FvfError(f"view must be a fvf.viz.View, a tuple or a dict; got {type(view)!r}")
    if out.up not in (*UP_AXES, "auto"):
        raise FvfError(f"view.up must be 'auto' or one of {', '.join(UP_AXES)}; got {out.up!r}")
    if not (isinstance(out.zoom, int | float) and 0 < out.zoom < np.inf):
        raise ParameterError(f"view.zoom must be a positive finite number; got {out.zoom!r}")
    for name in ("azimuth", "elevation"):
        angle = getattr(out, name)
        if name == "azimuth" and angle is None:
            continue
        if not (isinstance(angle, int | float | np.floating) and np.isfinite(angle)):
            raise ParameterError(f"view.{name} must be a finite number of degrees; got {angle!r}")
    return out


def _is_many(view: object) -> TypeGuard[list | tuple]:
    """A list of views (each a View, dict or tuple), not one view given as a tuple."""
    return (
        isinstance(view, (list, tuple))
        and bool(view)
        and all(isinstance(x, (View, dict, tuple, list)) for x in view)
    )


def as_views(view: object) -> list[View]:
    """One or several views: a View / tuple / dict / None, or a list of them."""
    if _is_many(view):
        return [as_view(x) for x in view]
    if view is None or isinstance(view, View | tuple | dict):
        return [as_view(view)]
    raise FvfError(f"view must be a fvf.viz.View, a tuple or a dict; got {type(view)!r}")


def two_sides(view: View | tuple | dict | None = None) -> list[View]:
    """``view`` and the same view from the opposite side (azimuth + 180°).

    Pass the result as ``view=`` to :func:`fvf.viz.render` to draw both halves of a closed
    surface side by side. With ``azimuth=None`` the automatic three-quarter azimuth is
    turned, so the second panel shows exactly the hidden side.
    """
    v = as_view(view)
    return [v, replace(v, turn=v.turn + 180.0)]


def aim(view: object, azimuth: float, elevation: float) -> list[View]:
    """``view`` (one view or a list, as :func:`as_views` takes) looking from ``azimuth``
    and ``elevation`` degrees, each view keeping its ``turn``, ``up`` and ``zoom``: the
    two views of :func:`two_sides` stay opposite (``fvf demo --view AZ EL``)."""
    return [replace(v, azimuth=float(azimuth), elevation=float(elevation)) for v in as_views(view)]


def resolve_up(
    view: View, points: np.ndarray, centroid: np.ndarray | None = None, up: str | None = None
) -> View:
    """``view`` with ``up="auto"`` replaced by ``up``, or else :func:`detect_up_axis` of the
    points (a view's explicit ``up`` is kept)."""
    if view.up != "auto":
        return view
    return replace(view, up=detect_up_axis(points, centroid) if up is None else up)


def _stability(points: np.ndarray, centroid: np.ndarray, k: int) -> float:
    """How well the shape stands on its −axis-k side, in fractions of its footprint size.

    The signed distance from the centroid's projection to the boundary of the convex hull
    of the support (the points within :data:`SUPPORT_BAND` of the height above the lowest
    one), positive inside, divided by the square root of the footprint's bounding-box area.
    """
    from scipy.spatial import ConvexHull, QhullError

    h = points[:, k]
    height = float(np.ptp(h))
    if not height > 0:
        return -1.0
    support = points[h <= h.min() + SUPPORT_BAND * height]
    others = [i for i in range(3) if i != k]
    foot = float(np.sqrt(np.prod(np.ptp(points[:, others], axis=0))))
    if support.shape[0] < 3 or not foot > 0:
        return -1.0
    try:
        hull = ConvexHull(support[:, others])
    except (QhullError, ValueError):  # collinear support: a knife edge
        return -1.0
    inside = -float((hull.equations[:, :2] @ centroid[others] + hull.equations[:, 2]).max())
    return inside / foot


#: A shape is mirror-symmetric about the plane normal to an axis when reflecting it there
#: moves its points by a median of less than this fraction of its bounding-box diagonal ...
MIRROR_TOLERANCE = 0.01
#: ... and less than this fraction of the same distance for the next most symmetric axis.
MIRROR_CONTRAST = 0.4
#: Points of a large mesh reflected to measure its symmetry.
_MIRROR_SAMPLES = 4000


def mirror_axis(points: np.ndarray, centroid: np.ndarray | None = None) -> int | None:
    """The axis normal to the shape's plane of mirror symmetry, if it clearly has one.

    Bodies, animals, busts and most objects people scan are left-right symmetric, and the
    axis across that plane is never their up axis. For each axis k the points (up to
    4000 of them, a seeded sample) are reflected through the plane normal to k through the
    centroid, and the median distance from a reflected point to the nearest point of the
    shape, over the bounding-box diagonal, is the mirror error $e_k$. The axis is returned
    when $e_k <$ :data:`MIRROR_TOLERANCE` and $e_k <$ :data:`MIRROR_CONTRAST` times the
    other two (a sphere or a box, symmetric about every axis, has none).

    Parameters
    ----------
    points : ndarray float64 (n, 3)
        The mesh's vertices.
    centroid : ndarray (3,), optional
        The centre of mass (default: the mean of the points).

    Returns
    -------
    int or None
        0, 1 or 2 (x, y, z), or None.
    """
    from scipy.spatial import cKDTree

    P = np.asarray(points, dtype=float)
    c = P.mean(0) if centroid is None else np.asarray(centroid, dtype=float)
    diag = float(np.linalg.norm(np.ptp(P, axis=0)))
    if P.shape[0] < 4 or not diag > 0:
        return None
    sample = P
    if P.shape[0] > _MIRROR_SAMPLES:
        rng = np.random.default_rng(0)
        sample = P[rng.choice(P.shape[0], _MIRROR_SAMPLES, replace=False)]
    tree = cKDTree(P)
    errors = np.empty(3)
    for k in range(3):
        Q = sample.copy()
        Q[:, k] = 2.0 * c[k] - Q[:, k]
        errors[k] = np.median(tree.query(Q)[0]) / diag
    order = np.argsort(errors)
    best, second = errors[order[0]], errors[order[1]]
    if best < MIRROR_TOLERANCE and best < MIRROR_CONTRAST * second:
        return int(order[0])
    return None


def _stability_of(points: np.ndarray, centroid: np.ndarray, up: str) -> float:
    """:func:`_stability` standing on the side opposite to ``up`` (``"-x"``: on +x)."""
    k = _AXES[up[-1]]
    if up.startswith("-"):
        return _stability(-points, -centroid, k)
    return _stability(points, centroid, k)


def detect_up_axis(points: np.ndarray, centroid: np.ndarray | None = None) -> str:
    """The axis that is up in a scan: ``"y"`` unless the shape clearly stands on another.

    The rule: a shape "stands" on the side of an axis when the centroid's projection lies
    well inside the convex hull of its lowest points along that axis (its support: feet,
    paws, the flat base of a bust); the *stability* is how far inside, in footprint sizes.
    The candidates are y (the OBJ and glTF convention) and z (scans and CAD); y is kept
    unless z stands with a positive stability larger than y's by :data:`UP_MARGIN`, and
    z is never up when it is the thinnest extent of the bounding box or the axis across
    the shape's mirror plane (a flat object lying in the xy plane is looked at from +z,
    which ``up="y"`` does). A shape whose plane of mirror symmetry has the y normal
    (:func:`mirror_axis`; bodies and animals are left-right symmetric, and the axis
    across is never up) cannot be y-up: of z, x and −x (the thinnest extent left out)
    the one it stands on best is up: a body or an animal stored x-up. When x and z tie
    for the thinnest extent (a wedge with equal legs, a cube) none is left: y.

    Measured on the shared meshes (stability on −y, −z): Nefertiti −0.02, +0.23 → z;
    armadillo +0.08, −0.25; spot +0.16, −0.18; lion +0.24, −0.24; bunny +0.27, −0.49;
    camel head +0.02, −0.23; bob +0.30, +0.03; FAUST +0.14, +0.05 → y. Turned x-up, spot,
    lion, armadillo, FAUST, the knight and a generated body and four-legged animal are
    found x-up (their mirror plane then has the y normal). A sphere stands equally on
    every side → y.

    Parameters
    ----------
    points : ndarray float64 (n, 3)
        The mesh's vertices.
    centroid : ndarray (3,), optional
        The centre of mass (default: the mean of the points).

    Returns
    -------
    {"y", "z", "x", "-x"}
    """
    P = np.asarray(points, dtype=float)
    c = P.mean(0) if centroid is None else np.asarray(centroid, dtype=float)
    ext = np.ptp(P, axis=0)
    mirror = mirror_axis(P, c)
    if mirror == 1:  # y is across the mirror plane: the candidate standing best
        candidates = [a for a in ("z", "x", "-x") if ext[_AXES[a[-1]]] > ext.min()]
        return max(candidates, key=lambda a: _stability_of(P, c, a), default="y")
    candidates = [a for a in ("z",) if _AXES[a] != mirror and ext[_AXES[a]] > ext.min()]
    scores = {a: _stability_of(P, c, a) for a in candidates}
    sy = _stability_of(P, c, "y")
    best = max(candidates, key=scores.__getitem__, default=None)
    if best is not None and scores[best] > 0 and scores[best] > sy + UP_MARGIN:
        return best
    return "y"


def camera_frame(view: View, points: np.ndarray) -> np.ndarray:
    """The camera's orthonormal frame for ``view`` looking at ``points``.

    Parameters
    ----------
    view : View
        ``up="auto"`` is resolved here with :func:`detect_up_axis` of ``points`` (use
        :func:`resolve_up` first to pass an area-weighted centroid).
    points : ndarray (n, 3)
        The mesh's vertices (used by the automatic azimuth and up axis).

    Returns
    -------
    ndarray float64 (3, 3)
        Rows ``right, up, back``: screen x, screen y, and the unit direction from the
        target toward the eye (larger ``⟨p, back⟩`` is nearer the eye).
    """
    up_axis = detect_up_axis(points) if view.up == "auto" else view.up
    k, sign = _AXES[up_axis[-1]], -1.0 if up_axis.startswith("-") else 1.0
    # (right, up, front) right-handed: turning up over keeps the front and flips the right
    u, f0, r0 = sign * np.eye(3)[k], np.eye(3)[(k + 1) % 3], sign * np.eye(3)[(k + 2) % 3]
    az = view.azimuth
    if az is None:
        ext = np.ptp(points, axis=0)
        az = (90.0 if ext[(k + 2) % 3] < ext[(k + 1) % 3] else 0.0) + 30.0
    az = az + view.turn
    a, e = np.radians(az), np.radians(view.elevation)
    back = np.cos(e) * (np.cos(a) * f0 + np.sin(a) * r0) + np.sin(e) * u
    right = np.cross(u, back)
    norm = np.linalg.norm(right)
    if norm < 1e-9:  # looking straight down the up axis
        right = np.cos(a) * r0 - np.sin(a) * f0
    else:
        right = right / norm
    up = np.cross(back, right)
    return np.stack([right, up, back])
