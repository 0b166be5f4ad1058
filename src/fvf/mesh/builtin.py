"""The built-in mesh shipped with the package: Spot the cow.

The chapter's scenes built on meshes (the fields of Fig. 12, the compressible case) need
the calculus, a layer above the meshes, and live in :mod:`fvf.examples`.
"""

from __future__ import annotations

import warnings
from importlib import resources
from pathlib import Path

import numpy as np

from .trimesh import TriMesh

__all__ = ["spot", "spot_path"]

#: Names that moved to :mod:`fvf.examples`: still reachable here, with a DeprecationWarning.
_MOVED = ("fig12_fields", "compressible_case")


def spot_path() -> str:
    """Path of the bundled ``spot.obj`` (Keenan Crane, CC0 1.0): 2930 vertices, 5856 faces."""
    return str(resources.files("fvf.mesh") / "data" / "spot.obj")


def spot() -> TriMesh:
    """Spot the cow (Keenan Crane, CC0 1.0): closed, genus 0, 2930 vertices, 5856 faces.

    The same arrays as ``fvf.read_mesh(spot_path())``, read here without the file layer:
    the bundled file has only ``v x y z``, ``vt u v`` and ``f a/ta b/tb c/tc`` lines.
    """
    return TriMesh(*_read_bundled_obj(spot_path()))


def _read_bundled_obj(path: str) -> tuple[np.ndarray, np.ndarray]:
    """Vertices float64 (n, 3) and triangles int64 (m, 3) of an OBJ file fvf ships.

    Reads ``v`` and ``f`` lines only (texture indices after ``/`` dropped): enough for the
    package's own data, not for users' files (:func:`fvf.read_mesh` checks those).
    """
    words = [line.split() for line in Path(path).read_text().splitlines()]
    V = np.array([w[1:4] for w in words if w and w[0] == "v"], dtype=np.float64)
    corners = [[c.partition("/")[0] for c in w[1:4]] for w in words if w and w[0] == "f"]
    return V, np.array(corners, dtype=np.int64) - 1


def __getattr__(name: str) -> object:
    if name not in _MOVED:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    warnings.warn(
        f"fvf.mesh.builtin.{name} moved to fvf.examples.{name}",
        DeprecationWarning,
        stacklevel=2,
    )
    # The one import of a layer above (docs/architecture.md): a deprecated alias only.
    from .. import examples

    return getattr(examples, name)
