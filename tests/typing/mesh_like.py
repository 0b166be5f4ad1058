"""Checked by mypy (``files`` in pyproject.toml), not run by pytest: every function taking
a mesh accepts what :data:`fvf.MeshLike` names, for type checkers too."""

from __future__ import annotations

from pathlib import Path

import numpy as np

import fvf

mesh = fvf.icosphere(2)
V, F = mesh.vertices, mesh.faces
directions = mesh.face_edge_vectors[[0], 0]

v1: np.ndarray = fvf.design_field((V, F), [0], directions)
v2: np.ndarray = fvf.design_field(mesh, [0], directions)
v3: np.ndarray = fvf.design_field("sphere.obj", [0], directions)
v4: np.ndarray = fvf.design_field(Path("sphere.obj"), [0], directions)
g: np.ndarray = fvf.gradient((V, F), V[:, 0])
m: fvf.TriMesh = fvf.as_mesh(Path("sphere.obj"))
like: fvf.MeshLike = (V, F)
transport = fvf.FieldTransport((V, F), v1)
f, energy = fvf.rescale((V, F), v1, v2, 0.1, return_energy=True)
e: float = energy
