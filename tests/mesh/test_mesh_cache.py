"""The declared cache of a TriMesh (fvf.mesh.cache): every key used in the source is
declared, undeclared names are refused, and dropping values frees them while the
recomputed values are bit for bit the ones dropped."""

from __future__ import annotations

import ast
from pathlib import Path

import numpy as np
import pytest
import scipy.sparse as sp

import fvf
from fvf import calculus
from fvf.design import connection, holonomy
from fvf.mesh import geometry
from fvf.mesh.cache import CACHED_QUANTITIES, quantity_name, value_nbytes
from fvf.mesh.geometry import vertex_vector_areas
from fvf.operators.directional import D_V, extract_field
from fvf.param.features import dihedral_angles
from fvf.param.quad_folds import closest_surface_points
from fvf.spectral.evaluation import geodesic_distances

SRC = Path(__file__).resolve().parents[2] / "src" / "fvf"


def cache_keys_in_source() -> list[tuple[str, int, str | None]]:
    """(file, line, declared name or None) of every ``<x>.cached(key, ...)`` call in src.

    The name is the literal part of the key before ``":"``; None when the key is not a
    string literal or an f-string starting with the name.
    """
    found = []
    for path in sorted(SRC.rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text())):
            if not (
                isinstance(node, ast.Call)
                and isinstance(node.func, ast.Attribute)
                and node.func.attr == "cached"
                and node.args
            ):
                continue
            key = node.args[0]
            if isinstance(key, ast.JoinedStr) and key.values:
                key = key.values[0]
            literal = key.value if isinstance(key, ast.Constant) else None
            name = literal.split(":", 1)[0] if isinstance(literal, str) else None
            found.append((str(path.relative_to(SRC)), node.lineno, name))
    return found


def test_every_cache_key_in_the_source_is_declared():
    found = cache_keys_in_source()
    assert len(found) >= 25, "the scan finds the cached() calls"
    bad = [f"{f}:{line}: {name!r}" for f, line, name in found if name not in CACHED_QUANTITIES]
    assert not bad, "cached() keys not declared in fvf.mesh.cache (or not literal):\n" + "\n".join(
        bad
    )
    unused = set(CACHED_QUANTITIES) - {name for _, _, name in found}
    assert not unused, f"declared but never cached: {sorted(unused)}"


def test_declarations_say_what_each_value_is_and_costs():
    for name, q in CACHED_QUANTITIES.items():
        assert q.name == name and ":" not in name
        assert q.description and q.memory and q.users
        module, _, function = q.owner.rpartition(".")
        assert callable(getattr(__import__(module, fromlist=[function]), function)), q.owner


def test_undeclared_names_are_refused():
    mesh = fvf.icosphere(1)
    with pytest.raises(fvf.UndeclaredCacheKeyError, match="declare it"):
        mesh.cached("my_operator", lambda: 1)
    with pytest.raises(fvf.UndeclaredCacheKeyError):
        mesh.clear_cache("my_operator")
    with pytest.raises(fvf.UndeclaredCacheKeyError):
        mesh.peek_cached("my_operator")
    assert mesh.cached("grad:a variant", lambda: 2) == 2  # a declared name with a variant
    assert quantity_name("connection_laplacian:knoppel:4") == "connection_laplacian"


def fill_cache(mesh: fvf.TriMesh) -> dict[str, object]:
    """Compute every declared quantity on ``mesh``; returns results that depend on them."""
    rng = np.random.default_rng(7)
    v = mesh.project_tangent(rng.standard_normal((mesh.n_faces, 3)))
    for op in (fvf.grad, fvf.div, fvf.laplacian, fvf.vertex_mass, fvf.rotation):
        op(mesh)
    for op in (fvf.face_to_vertex, fvf.vertex_to_face, calculus.hat_gradients):
        op(mesh)
    fvf.face_mass(mesh, 1), fvf.face_mass(mesh)
    results: dict[str, object] = {
        "D_V": D_V(mesh, v),
        "field": extract_field(mesh, fvf.D_F(mesh, v)),
    }
    results["indices"] = fvf.vertex_indices(mesh, v, zero="warn")
    results["curvatures"] = fvf.principal_curvatures(mesh)
    ell = 3 * mesh.mean_edge_length
    for kind in connection.KINDS:
        connection.real_connection_laplacian(mesh, kind)
        connection.sample_points(mesh, kind)
    connection.connection_laplacian(mesh, n=4, curvature_smoothing=ell)
    connection.connection_mass(mesh), connection.connection_mass(mesh, real=True)
    connection.tangent_basis_matrix(mesh)
    results["rotations"] = holonomy.holonomy_rotations(mesh, ell)
    for method in ("unfolded", "edges", "heat"):
        results[method] = geodesic_distances(mesh, [0, 5], method=method)
    results["closest"] = closest_surface_points(mesh, 1.01 * mesh.vertices, exact=True)
    results["vector areas"] = vertex_vector_areas(mesh)
    results["dihedral"] = dihedral_angles(mesh)
    return results


def arrays_of(value: object) -> list[tuple[str, tuple, bytes]]:
    """(dtype, shape, bytes) of every array a value holds, in a fixed order."""
    if isinstance(value, np.ndarray):
        return [(value.dtype.str, value.shape, value.tobytes())]
    if sp.issparse(value):
        return [a for p in ("data", "indices", "indptr") for a in arrays_of(getattr(value, p))]
    if isinstance(value, (tuple, list)):
        return [a for v in value for a in arrays_of(v)]
    if hasattr(value, "__dict__") and not isinstance(value, fvf.TriMesh):
        return [a for k in sorted(vars(value)) for a in arrays_of(vars(value)[k])]
    return []


def test_clear_cache_frees_and_recomputes_identical_bits():
    mesh = fvf.jittered_sphere(2, seed=3)
    before = fill_cache(mesh)
    info = mesh.cache_info()
    assert {quantity_name(k) for k in info} == set(CACHED_QUANTITIES)
    assert all(size > 0 for size in info.values()), info
    G = fvf.grad(mesh)
    assert info["grad"] == G.data.nbytes + G.indices.nbytes + G.indptr.nbytes
    held = {key: mesh.peek_cached(key) for key in info}
    snapshot = {key: arrays_of(value) for key, value in held.items()}

    freed = mesh.clear_cache()
    assert freed == value_nbytes(list(held.values())) > 0
    assert mesh.cache_info() == {} and mesh.peek_cached("grad") is None

    after = fill_cache(mesh)
    assert mesh.cache_info().keys() == info.keys()
    for key, value in held.items():
        again = mesh.peek_cached(key)
        assert again is not value, key  # recomputed, not kept
        assert arrays_of(again) == snapshot[key], f"{key} differs after recomputation"
    for key in ("D_V", "field", "indices", "rotations", "unfolded", "edges", "heat"):
        assert arrays_of(after[key]) == arrays_of(before[key]), key


def test_clear_cache_by_name_drops_every_variant_and_nothing_else():
    mesh = fvf.icosphere(2)
    fvf.face_mass(mesh, 1), fvf.face_mass(mesh, 3), fvf.grad(mesh), fvf.laplacian(mesh)
    assert {"face_mass:1", "face_mass:3", "grad", "stiffness", "laplacian"} <= set(
        mesh.cache_info()
    )
    L = fvf.laplacian(mesh)
    assert mesh.clear_cache(["face_mass", "laplacian"]) > 0
    left = set(mesh.cache_info())
    assert {"grad", "stiffness"} <= left
    assert not {k for k in left if quantity_name(k) in ("face_mass", "laplacian")}
    assert fvf.laplacian(mesh) is not L and (fvf.laplacian(mesh) != L).nnz == 0
    assert mesh.clear_cache("face_mass:3") == 0  # a full key: already dropped
    fvf.face_mass(mesh, 3)
    assert mesh.clear_cache("face_mass:3") > 0 and "face_mass:3" not in mesh.cache_info()


def test_peek_cached_never_builds():
    mesh = fvf.icosphere(1)
    assert mesh.peek_cached("centered_vertices") is None
    X = geometry.centered_vertices(mesh)
    assert mesh.peek_cached("centered_vertices") is X and not X.flags.writeable


def test_vertex_vector_areas_sum_to_the_enclosed_surface_vector_area():
    """Σ_i Σ_{t∋i} A_t n_t = 3 Σ_t A_t n_t = 0 on a closed surface; on a flat square
    every vertex's vector area is normal to the plane with length the area around it."""
    sphere = fvf.jittered_sphere(2, seed=1)
    N = vertex_vector_areas(sphere)
    assert N.shape == (sphere.n_vertices, 3) and not N.flags.writeable
    assert np.abs(N.sum(axis=0)).max() < 1e-12
    assert np.all(np.einsum("ij,ij->i", N, sphere.vertices) > 0)  # outwards
    V = np.array([[0.0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]])
    square = fvf.TriMesh(V, np.array([[0, 1, 2], [0, 2, 3]]))
    assert np.allclose(
        vertex_vector_areas(square), [[0, 0, 1], [0, 0, 0.5], [0, 0, 1], [0, 0, 0.5]]
    )
