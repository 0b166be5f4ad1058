"""Built-in meshes shipped with the package."""

from __future__ import annotations

from importlib import resources

from .mesh import TriMesh

__all__ = ["spot", "spot_path"]


def spot_path() -> str:
    """Path of the bundled ``spot.obj`` (Keenan Crane, CC0 1.0): 2930 vertices, 5856 faces."""
    return str(resources.files("fvf") / "data" / "spot.obj")


def spot() -> TriMesh:
    """Spot the cow (Keenan Crane, CC0 1.0): closed, genus 0, 2930 vertices, 5856 faces."""
    from .io import read_mesh

    return TriMesh(*read_mesh(spot_path()))
