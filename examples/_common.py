"""What every example script shares: its command line, the mesh, and optional pictures.

Each script runs as ``python examples/<script>.py [MESH] [--out DIR] [--no-pictures]``:
MESH is an OBJ/OFF/PLY file (default: the built-in Spot, 2930 vertices), DIR receives the
pictures (default: a new temporary folder, named when the script starts; nothing is
written into the repository). Pictures need the ``[viz]`` extra
(``pip install 'fvf[viz]'``); without it the script still computes and prints every
number, and says that it skipped the picture.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from collections.abc import Callable
from pathlib import Path

import numpy as np

import fvf


def parse_args(description: str, default: str = "the built-in Spot") -> argparse.Namespace:
    """The command line shared by all examples."""
    parser = argparse.ArgumentParser(description=description)
    parser.add_argument("mesh", nargs="?", help=f"OBJ/OFF/PLY mesh (default: {default})")
    parser.add_argument("--out", help="folder for the pictures (default: a new temporary folder)")
    parser.add_argument("--no-pictures", action="store_true", help="numbers only")
    args = parser.parse_args()
    if args.out is None and not args.no_pictures:
        args.out = tempfile.mkdtemp(prefix="fvf-examples-")
        print(f"pictures go to {args.out} (choose the folder with --out DIR)")
    return args


def load_mesh(path: str | None) -> fvf.TriMesh:
    """The mesh at ``path``, or the built-in Spot when ``path`` is None.

    A file that cannot be read ends the script with one line and status 2, as ``fvf``
    does; a mesh that needs repair (unreferenced vertices, an unwelded soup, ...) is
    repaired with :func:`fvf.repair_mesh`, saying what changed.
    """
    if not path:
        mesh = fvf.mesh.builtin.spot()
    else:
        try:
            V, F = fvf.read_mesh(path)
        except (fvf.FvfError, OSError) as exc:
            _fail(f"error: {' '.join(str(exc).split())}")
        try:
            mesh = fvf.TriMesh(V, F)
        except fvf.MeshError as exc:
            print(f"note: {path} needs repair ({type(exc).__name__}); running fvf.repair_mesh")
            try:
                fixed = fvf.repair_mesh(V, F)
                mesh = fixed.mesh
            except fvf.FvfError as again:
                _fail(f"error: {path} cannot be repaired: {' '.join(str(again).split())}")
            for line in fixed.log:
                print(f"  {line}")
    print(f"mesh: {path or 'built-in spot.obj'} ({mesh.n_vertices} vertices, {mesh.n_faces} faces)")
    return mesh


def _fail(message: str) -> None:
    """One line on stderr and exit status 2 (bad input), as the fvf command does."""
    print(message, file=sys.stderr)
    sys.exit(2)


def unit_radius(mesh: fvf.TriMesh) -> fvf.TriMesh:
    """The mesh centred at its vertex mean and scaled so that its farthest vertex is at 1."""
    X = mesh.vertices - mesh.vertices.mean(0)
    return fvf.TriMesh(X / np.linalg.norm(X, axis=1).max(), mesh.faces)


def scaled_coordinate(X: np.ndarray, k: int) -> np.ndarray:
    """Coordinate k of the vertices X (n, 3) divided by its extent, (n,).

    On a flat mesh whose coordinate k is constant, the coordinate of largest extent is
    used instead, so that the example's functions still vary.
    """
    extent = np.ptp(X, axis=0)
    if extent[k] <= 1e-9 * extent.max():
        k = int(extent.argmax())
    return X[:, k] / extent[k]


def l2(mesh: fvf.TriMesh, field: np.ndarray) -> float:
    """L2 norm (eq. 26) of a per-face field (m, 3) or a per-vertex field (n, 3)."""
    weights = mesh.face_areas if len(field) == mesh.n_faces else mesh.vertex_areas
    return float(np.sqrt(weights @ (field * field).sum(1)))


def report(name: str, value) -> None:
    """Print one measured number, ``name: value``."""
    if isinstance(value, float):
        value = f"{value:.6g}"
    print(f"  {name}: {value}", flush=True)


def picture(args: argparse.Namespace, name: str, draw: Callable) -> Path | None:
    """Call ``draw(viz, path)`` with the module :mod:`fvf.viz` and ``out/name``.

    Returns the path written, or None when pictures are off or the ``[viz]`` extra is
    missing (saying so).
    """
    if args.no_pictures:
        print(f"picture {name}: skipped (--no-pictures)")
        return None
    try:
        from fvf import viz

        out = Path(args.out)
        out.mkdir(parents=True, exist_ok=True)
        path = out / name
        draw(viz, path)
    except ImportError as exc:  # the [viz] extra is optional (MissingExtraError included)
        print(f"picture {name}: skipped, the [viz] extra is missing ({exc})")
        return None
    print(f"picture: wrote {path}")
    return path


def strip(viz, mesh: fvf.TriMesh, path: Path, panels: list[dict], size=(400, 320)) -> Path:
    """Render one picture per dict of :func:`fvf.viz.render` keywords; paste them in a row.

    A panel's ``"mesh"`` key, if any, replaces ``mesh`` for that panel. Every panel is
    rendered to ``path`` with a ``_<i>`` suffix first; the row is written to ``path`` and
    the single panels are removed.
    """
    from PIL import Image  # part of the [viz] extra

    parts = []
    for i, keywords in enumerate(panels):
        part = path.with_name(f"{path.stem}_{i}{path.suffix}")
        keywords = dict(keywords)
        viz.render(keywords.pop("mesh", mesh), part, size=size, **keywords)
        parts.append(part)
    images = [Image.open(p).convert("RGB") for p in parts]
    row = Image.new(
        "RGB", (sum(im.width for im in images), max(im.height for im in images)), "white"
    )
    x = 0
    for im in images:
        row.paste(im, (x, 0))
        x += im.width
    row.save(path)
    for p in parts:
        p.unlink()
    return path
