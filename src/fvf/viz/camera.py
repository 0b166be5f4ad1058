"""Where the camera looks from: a :class:`View` and its orthonormal camera frame.

Both backends use the same frame, so a picture made by polyscope and one made by
matplotlib show the mesh from the same side.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import FvfError, ParameterError

__all__ = ["View", "as_view", "camera_frame"]

_AXES = {"x": 0, "y": 1, "z": 2}


@dataclass(frozen=True)
class View:
    """A camera direction around the mesh.

    Attributes
    ----------
    azimuth : float or None
        Degrees about the up axis, from the "front" axis (the axis after ``up`` in x, y, z
        order: +z for ``up="y"``) toward the "right" axis (+x for ``up="y"``). None picks
        the side of the mesh's bounding box with the larger silhouette and turns 30° from
        it (a three-quarter view).
    elevation : float
        Degrees above the horizontal plane.
    up : {"x", "y", "z"}
        The axis drawn vertical. OBJ files (spot among them) are usually y-up.
    zoom : float
        > 1 fills more of the picture (1 fits the whole mesh with a small margin).
    """

    azimuth: float | None = None
    elevation: float = 20.0
    up: str = "y"
    zoom: float = 1.0


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
    if out.up not in _AXES:
        raise FvfError(f"view.up must be 'x', 'y' or 'z'; got {out.up!r}")
    if not (isinstance(out.zoom, int | float) and 0 < out.zoom < np.inf):
        raise ParameterError(f"view.zoom must be a positive finite number; got {out.zoom!r}")
    for name in ("azimuth", "elevation"):
        angle = getattr(out, name)
        if name == "azimuth" and angle is None:
            continue
        if not (isinstance(angle, int | float | np.floating) and np.isfinite(angle)):
            raise ParameterError(f"view.{name} must be a finite number of degrees; got {angle!r}")
    return out


def camera_frame(view: View, points: np.ndarray) -> np.ndarray:
    """The camera's orthonormal frame for ``view`` looking at ``points``.

    Parameters
    ----------
    view : View
    points : ndarray (n, 3)
        The mesh's vertices (used by the automatic azimuth).

    Returns
    -------
    ndarray float64 (3, 3)
        Rows ``right, up, back``: screen x, screen y, and the unit direction from the
        target toward the eye (larger ``⟨p, back⟩`` is nearer the eye).
    """
    k = _AXES[view.up]
    u, f0, r0 = np.eye(3)[k], np.eye(3)[(k + 1) % 3], np.eye(3)[(k + 2) % 3]
    az = view.azimuth
    if az is None:
        ext = np.ptp(points, axis=0)
        az = (90.0 if ext[(k + 2) % 3] < ext[(k + 1) % 3] else 0.0) + 30.0
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
