"""Shared fixtures: the real meshes of ``../shared/meshes`` (skipped cleanly when absent)."""

from __future__ import annotations

import importlib
import os
import sys
from pathlib import Path

import numpy as np
import pytest

try:  # small dense work (ARPACK, k x k algebra) is 10-25x slower with threaded OpenBLAS here
    import scipy.linalg  # noqa: F401  (load scipy's own OpenBLAS first, so the limit covers it)
    from threadpoolctl import threadpool_limits

    threadpool_limits(1)
except ImportError:  # pragma: no cover
    pass

_DEFAULT = Path(__file__).resolve().parents[2] / "shared" / "meshes"
SHARED_MESHES = Path(os.environ.get("FVF_SHARED_MESHES", _DEFAULT))


BENCHMARKS = Path(__file__).resolve().parents[1] / "benchmarks"


def import_benchmark(name: str):
    """The module ``benchmarks/<name>.py`` of this checkout, imported with its folder on
    ``sys.path`` (the benchmark scripts import each other by name)."""
    if str(BENCHMARKS) not in sys.path:
        sys.path.insert(0, str(BENCHMARKS))
    return importlib.import_module(name)


def shared_mesh_path(name: str) -> Path:
    """Path of ``../shared/meshes/<name>``; skips the calling test when it is absent."""
    path = SHARED_MESHES / name
    if not path.exists():
        pytest.skip(f"shared mesh {name} not available (set FVF_SHARED_MESHES)")
    return path


@pytest.fixture
def rng():
    """A seeded generator: every test's randomness is reproducible."""
    return np.random.default_rng(20261122)


# Closed meshes of ../shared/meshes small enough for the fast suite (name, chi).
CLOSED_SHARED = [
    ("decimated-knight.off", 2),
    ("spot.obj", 2),
    ("bunny-lowres.off", 2),
    ("fertility.off", -6),
    ("bob_tri.obj", 0),
    ("3holes.off", -4),
    ("sphere_s2.off", 2),
    ("faust_r_tr_reg_001.off", 2),
    ("lion-00.off", 2),
]
BOUNDARY_SHARED = [("woody.obj", 1, 1), ("camelhead.off", 1, 1)]  # (name, chi, loops)

_LOADED: dict = {}


def load_shared(name: str):
    """A TriMesh of a shared mesh (cached per session; skips when absent)."""
    import fvf

    path = shared_mesh_path(name)
    if name not in _LOADED:
        V, F = fvf.read_mesh(path)
        if name == "stanford-bunny.obj":
            V, F, _ = fvf.remove_unreferenced_vertices(V, F)
        _LOADED[name] = fvf.TriMesh(V, F)
    return _LOADED[name]


def generated_closed():
    """Generated closed meshes: regular and jittered spheres, a torus."""
    import fvf

    return {
        "icosphere2": fvf.icosphere(2),
        "jittered2": fvf.jittered_sphere(2, 0.35, seed=1),
        "torus": fvf.torus(24, 12),
    }


_GENERATED: dict = {}


def closed_mesh(name: str):
    if name in dict(CLOSED_SHARED):
        return load_shared(name)
    if not _GENERATED:
        _GENERATED.update(generated_closed())
    return _GENERATED[name]


CLOSED_NAMES = ["icosphere2", "jittered2", "torus"] + [n for n, _ in CLOSED_SHARED]


@pytest.fixture(params=CLOSED_NAMES)
def closed(request):
    """Every closed mesh of the corpus (generated + shared), one test per mesh."""
    return closed_mesh(request.param)


@pytest.fixture(params=["disk"] + [n for n, _, _ in BOUNDARY_SHARED])
def with_boundary(request):
    """Meshes with boundary: a generated disk, woody, camelhead."""
    import fvf

    if request.param == "disk":
        return fvf.disk(6, 6)
    return load_shared(request.param)


def random_tangent_field(mesh, rng, scale: float = 1.0):
    """A random tangent per-face field (m, 3)."""
    return scale * mesh.project_tangent(rng.standard_normal((mesh.n_faces, 3)))


def smooth_functions(mesh):
    """Three smooth PL functions of the (normalized) coordinates, (n,) each."""
    X = mesh.vertices
    X = (X - X.mean(0)) / np.abs(X - X.mean(0)).max()
    return (
        np.sin(2 * X[:, 0]) + X[:, 1] * X[:, 2],
        np.cos(3 * X[:, 1]) + X[:, 0],
        X[:, 2] ** 2 + 0.5 * X[:, 0],
    )


def rel(a, b) -> float:
    """max |a - b| / max(|b|, tiny) for arrays or sparse arrays."""
    import scipy.sparse as sp

    d = a - b
    d = abs(d).max() if sp.issparse(d) else np.abs(d).max()
    s = abs(b).max() if sp.issparse(b) else np.abs(b).max()
    return float(d / max(s, 1e-300))
