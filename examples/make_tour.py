"""Write ``examples/tour.ipynb`` (nbformat 4, no outputs) from the cells below.

Edit the cells here and run ``python examples/make_tour.py``; ``tests/test_examples.py``
checks that the committed notebook is what this script writes, and runs its code cells.
The cells are written in ``ruff format`` style and the keys sorted, as ruff and nbformat
write them, so ``ruff format examples`` leaves the notebook unchanged.
"""

from __future__ import annotations

import json
from pathlib import Path

CELLS = [
    (
        "markdown",
        """# A tour of fvf

Tangent vector fields as operators on functions, after *Operator-Based Representations of
Discrete Tangent Vector Fields* (Azencot, Ben-Chen et al.). Equation numbers are the
chapter's. Set the environment variable `FVF_EXAMPLE_MESH` to an OBJ/OFF/PLY file to run
the tour on your own mesh; the default is the built-in Spot.""",
    ),
    (
        "code",
        """import os
import tempfile
from pathlib import Path

import numpy as np

import fvf

path = os.environ.get("FVF_EXAMPLE_MESH")
mesh = fvf.TriMesh(*fvf.read_mesh(path)) if path else fvf.mesh.builtin.spot()
X = mesh.vertices
n, m = mesh.n_vertices, mesh.n_faces
print(f"{n} vertices, {m} faces, Euler characteristic {mesh.euler_characteristic}")""",
    ),
    (
        "markdown",
        """## Discrete calculus (§3.1) and functional vector fields (§3.2–3.3)

A field is one tangent 3-vector per face, an `(m, 3)` array. J grad h is divergence-free,
and the field is recovered from its operator D^F_v by applying it to the coordinates
(Lemma 9).""",
    ),
    (
        "code",
        """h = X[:, 1] + 0.5 * np.sin(3 * X[:, 0] / np.ptp(X[:, 0]))
v = fvf.rotate(mesh, fvf.gradient(mesh, h))  # J grad h, (m, 3)
w = fvf.gradient(mesh, X[:, 0])  # grad x, (m, 3)
div_v = fvf.divergence(mesh, v)  # (n,)
lemma9 = np.abs(fvf.extract_field(mesh, fvf.D_F(mesh, v)) - v).max()
print("max |div J grad h| =", np.abs(div_v).max())
print("max |D^F_v X - v|  =", lemma9)""",
    ),
    (
        "markdown",
        """## Flows (§3.4–3.5)

Φ_{v,t} f = exp(−t D^V_v) f carries a function along v (eq. 42). For v = J grad h the
flow keeps the A_V-norm.""",
    ),
    (
        "code",
        """phi = fvf.FunctionalFlow(mesh, v)
f0 = np.sin(4 * X[:, 2] / np.ptp(X[:, 2]))
times = np.linspace(0.0, 1.0, 5) * np.ptp(X[:, 0]) / np.abs(v).max()
frames = phi(f0, times)  # (5, n)
norm_drift = abs(phi.norm(frames[-1]) / phi.norm(f0) - 1)
print("relative norm drift:", norm_drift)""",
    ),
    (
        "markdown",
        """## Lie brackets (§3.6, §4.3)

The vertex bracket (46) is 2-ring sparse; the mixed bracket (54) is 1-ring (Lemma 16).
Applied to the coordinates, the mixed bracket gives the commutator field (Fig. 9).""",
    ),
    (
        "code",
        """BV = fvf.bracket_V(mesh, v, w)
BF = fvf.bracket_F(mesh, v, w)
L = fvf.laplacian(mesh)
u = fvf.commutator_field(mesh, v, w)  # (n, 3)
print("nnz: vertex bracket", BV.nnz, "| mixed bracket", BF.nnz, "| Laplacian", L.nnz)
print("mean |D^F_[v,w] X| =", np.linalg.norm(u, axis=1).mean())""",
    ),
    (
        "markdown",
        """## ad_v, rescaling and as-commuting-as-possible fields (§4.4, Figs. 10–11)""",
    ),
    (
        "code",
        """f = fvf.rescale(mesh, v, w, 10.0)  # (n,): makes f w commute better with v
acap = fvf.acap_fields(mesh, v, 1e-2, 2)  # (2, m, 3)
singular = [fvf.singularities(mesh, field) for field in acap]
for i, (ids, index) in enumerate(singular):
    print(f"ACAP field {i}: {len(ids)} singular vertices, index sum {index.sum()}")""",
    ),
    (
        "markdown",
        """## Transport and interpolation of fields (§4.5, eqs. 67–68, Fig. 12)""",
    ),
    (
        "code",
        """T = 0.1 * np.ptp(X[:, 0]) / np.abs(v).max()
u0 = acap[0]
u1 = fvf.Ad(mesh, v, u0, T)  # (m, 3): u0 carried along v for time T
halfway = fvf.interpolate(mesh, T * v, u0, u1, 0.5)
A_F = mesh.face_areas
change = np.sqrt(A_F @ ((u1 - u0) ** 2).sum(1) / (A_F @ (u0**2).sum(1)))
print("relative change of u0 under transport:", change)""",
    ),
    (
        "markdown",
        """## Pictures (needs the `[viz]` extra)

`fvf.viz.render` writes a PNG; without the extra this cell says so and does nothing.""",
    ),
    (
        "code",
        """pictures = []
try:
    from fvf import viz

    out = Path(tempfile.mkdtemp(prefix="fvf_tour_"))
    ids, index = singular[0]
    viz.render(
        mesh,
        out / "flow.png",
        function=frames[-1],
        texture=viz.lic_texture(mesh, v),
        title="f(t) and the LIC of v",
    )
    viz.render(
        mesh,
        out / "acap.png",
        field=acap[0],
        singularities=(fvf.singularity_positions(mesh, ids), index),
        title="ACAP field",
    )
    pictures = [out / "flow.png", out / "acap.png"]
except ImportError as exc:  # fvf.viz.MissingExtraError is an ImportError
    print("pictures skipped:", exc)
try:
    from IPython.display import Image, display

    for p in pictures:
        display(Image(filename=str(p)))
except ImportError:
    print("\\n".join(map(str, pictures)))""",
    ),
]


def notebook() -> dict:
    """The notebook as nbformat v4 JSON (a dict), without outputs."""
    cells = []
    for i, (kind, source) in enumerate(CELLS):
        cell = {
            "cell_type": kind,
            "id": f"cell-{i:02d}",
            "metadata": {},
            "source": source.splitlines(keepends=True),
        }
        if kind == "code":
            cell.update(execution_count=None, outputs=[])
        cells.append(cell)
    return {
        "cells": cells,
        "metadata": {
            "kernelspec": {"display_name": "Python 3", "language": "python", "name": "python3"},
            "language_info": {"name": "python"},
        },
        "nbformat": 4,
        "nbformat_minor": 5,
    }


def text() -> str:
    """The file's contents."""
    return json.dumps(notebook(), indent=1, sort_keys=True, ensure_ascii=False) + "\n"


if __name__ == "__main__":
    target = Path(__file__).with_name("tour.ipynb")
    target.write_text(text())
    print(f"wrote {target}")
