"""Principal curvatures against analytic ellipsoids, cylinders and tori, with rates;
curvature-aligned cross fields against the analytic principal directions."""

from __future__ import annotations

import numpy as np
import pytest

import fvf

# ---------------------------------------------------------------------------- surfaces


def _implicit_principal(P, grad, hess):
    """Analytic κ_1 ≥ κ_2, d1 of the implicit surface F = 0 at points P, outward normal ∇F."""
    g = grad(P)
    gn = np.linalg.norm(g, axis=1)
    N = g / gn[:, None]
    Pm = np.eye(3)[None] - N[:, :, None] * N[:, None, :]
    W = Pm @ hess(P) @ Pm / gn[:, None, None]
    lam, V = np.linalg.eigh(W)
    dots = np.abs(np.einsum("tij,ti->tj", V, N))
    order = np.argsort(dots, axis=1)[:, :2]  # the two tangent eigenvectors
    rows = np.arange(len(P))
    lt = np.take_along_axis(lam, order, 1)
    i1 = np.argmax(lt, axis=1)
    k1, k2 = lt[rows, i1], lt[rows, 1 - i1]
    d1 = V[rows, :, order[rows, i1]]
    return k1, k2, d1


def ellipsoid(k, a=(1.0, 0.8, 0.6)):
    a = np.asarray(a)
    s = fvf.icosphere(k)
    mesh = fvf.TriMesh(s.vertices * a, s.faces)

    def grad(P):
        return 2 * P / a**2

    def hess(P):
        return np.broadcast_to(np.diag(2 / a**2), (len(P), 3, 3))

    def project(C):
        return C / np.sqrt(((C / a) ** 2).sum(1))[:, None]

    return mesh, grad, hess, project


def torus(k, R=1.0, r=0.4):
    mesh = fvf.torus(2 * k, k, R, r)

    def grad(P):
        q = np.hypot(P[:, 0], P[:, 1])
        return np.stack([2 * (q - R) * P[:, 0] / q, 2 * (q - R) * P[:, 1] / q, 2 * P[:, 2]], 1)

    def hess(P, h=1e-6):
        return np.stack([(grad(P + h * e) - grad(P - h * e)) / (2 * h) for e in np.eye(3)], 2)

    def project(C):
        q = np.hypot(C[:, 0], C[:, 1])
        ctr = np.stack([R * C[:, 0] / q, R * C[:, 1] / q, 0 * q], 1)
        d = C - ctr
        return ctr + r * d / np.linalg.norm(d, axis=1)[:, None]

    return mesh, grad, hess, project


def cylinder(k, r=0.5, height=2.0, twist=0.0):
    """Open cylinder x² + y² = r², |z| ≤ height/2: (2k) × k grid, outward normals."""
    n_a, n_z = 2 * k, max(2, int(round(k * height / (2 * np.pi * r) * 2)))
    a = 2 * np.pi * np.arange(n_a) / n_a
    z = np.linspace(-height / 2, height / 2, n_z + 1)
    A, Z = np.meshgrid(a, z, indexing="ij")
    A = A + twist * Z
    X = np.stack([r * np.cos(A), r * np.sin(A), Z], -1).reshape(-1, 3)
    i, j = np.meshgrid(np.arange(n_a), np.arange(n_z), indexing="ij")
    p = i * (n_z + 1) + j
    q = ((i + 1) % n_a) * (n_z + 1) + j
    F = np.concatenate(
        [np.stack([p, q, q + 1], -1).reshape(-1, 3), np.stack([p, q + 1, p + 1], -1).reshape(-1, 3)]
    )
    mesh = fvf.TriMesh(X, F)

    def grad(P):
        return np.stack([2 * P[:, 0], 2 * P[:, 1], 0 * P[:, 2]], 1)

    def hess(P):
        return np.broadcast_to(np.diag([2.0, 2.0, 0.0]), (len(P), 3, 3))

    def project(C):
        q = np.hypot(C[:, 0], C[:, 1])
        return np.stack([r * C[:, 0] / q, r * C[:, 1] / q, C[:, 2]], 1)

    return mesh, grad, hess, project


def _errors(make, k):
    """Max |κ_i error| and the angle error of d1 (degrees, mod 180°) on anisotropic faces."""
    mesh, grad, hess, project = make(k)
    pc = fvf.principal_curvatures(mesh)
    k1, k2, d1 = _implicit_principal(project(mesh.face_centroids), grad, hess)
    N = mesh.face_normals
    d1 = d1 - np.einsum("ij,ij->i", d1, N)[:, None] * N
    d1 /= np.linalg.norm(d1, axis=1)[:, None]
    ang = np.degrees(np.arccos(np.clip(np.abs(np.einsum("ij,ij->i", d1, pc.d1)), 0, 1)))
    aniso = k1 - k2
    far = aniso > 0.3 * aniso.max()
    A = mesh.face_areas
    kerr = np.sqrt(A @ ((pc.k1 - k1) ** 2 + (pc.k2 - k2) ** 2) / A.sum())
    return mesh, kerr, np.abs(pc.k1 - k1).max(), ang[far].max(), A[far] @ ang[far] / A[far].sum()


def _rate(h, e):
    return np.polyfit(np.log(h), np.log(e), 1)[0]


def test_outward_orientation_of_generated_surfaces():
    for make, k in ((ellipsoid, 2), (torus, 12), (cylinder, 12)):
        mesh, grad, _, project = make(k)
        g = grad(project(mesh.face_centroids))
        assert (np.einsum("ij,ij->i", g, mesh.face_normals) > 0).all()


def test_sphere_is_umbilic_with_positive_curvature():
    pc = fvf.principal_curvatures(fvf.icosphere(4, radius=2.0))
    assert np.abs(pc.k1 - 0.5).max() < 2e-3 and np.abs(pc.k2 - 0.5).max() < 2e-3
    assert np.abs(pc.anisotropy).max() < 4e-3
    flipped = fvf.icosphere(3)
    flipped = fvf.TriMesh(flipped.vertices, flipped.faces[:, ::-1])
    assert np.allclose(fvf.principal_curvatures(flipped).k1, -1.0, atol=1e-2)


def test_flat_mesh_has_zero_curvature():
    pc = fvf.principal_curvatures(fvf.disk(4, 6))
    assert np.abs(pc.k1).max() < 1e-12 and np.abs(pc.k2).max() < 1e-12


def test_directions_are_orthonormal_tangent():
    mesh = torus(12)[0]
    pc = fvf.principal_curvatures(mesh)
    N = mesh.face_normals
    for d in (pc.d1, pc.d2):
        np.testing.assert_allclose(np.linalg.norm(d, axis=1), 1.0, atol=1e-12)
        assert np.abs(np.einsum("ij,ij->i", d, N)).max() < 1e-12
    assert np.abs(np.einsum("ij,ij->i", pc.d1, pc.d2)).max() < 1e-12
    assert (pc.k1 >= pc.k2).all()
    np.testing.assert_allclose(pc.gaussian, pc.k1 * pc.k2)
    np.testing.assert_allclose(pc.mean, 0.5 * (pc.k1 + pc.k2))


@pytest.mark.parametrize(
    "make, ks, value_rate, angle_rate",
    [
        (torus, (12, 24, 48), 0.9, 0.9),
        (cylinder, (8, 16, 32), None, None),  # exact on the cylinder's grid
        # icosphere-based ellipsoid: irregular valence, the RMS converges, the max does not
        (ellipsoid, (2, 3, 4), 0.5, 0.6),
    ],
)
def test_curvature_convergence(make, ks, value_rate, angle_rate):
    rows = [_errors(make, k) for k in ks]
    h = [r[0].mean_edge_length for r in rows]
    rms = [r[1] for r in rows]
    mean_angle = [r[4] for r in rows]
    if value_rate is None:  # exact values and directions on the cylinder's grid
        assert max(rms) < 1e-12 and max(r[3] for r in rows) < 1e-5  # degrees (arccos round-off)
    else:
        assert _rate(h, rms) >= value_rate, rms
        assert _rate(h, mean_angle) >= angle_rate, mean_angle
    if make is torus:
        assert _rate(h, [r[2] for r in rows]) >= 0.9  # pointwise too on the regular grid


# ---------------------------------------------------------------------------- alignment
def _aligned_angle_error(make, k, strength=1.0):
    mesh, grad, hess, project = make(k)
    u = fvf.design_field(mesh, n=4, align="curvature", align_strength=strength)
    k1, k2, d1 = _implicit_principal(project(mesh.face_centroids), grad, hess)
    d1 = mesh.project_tangent(d1)
    err = np.abs(np.angle(fvf.to_power(mesh, u, 4) * np.conj(fvf.to_power(mesh, d1, 4)))) / 4
    far = (k1 - k2) > 0.3 * (k1 - k2).max()
    return mesh, u, np.degrees(err[far]).max(), np.degrees(err[far]).mean()


def test_curvature_aligned_cross_field_on_torus_has_no_singularities_and_converges():
    rows = [_aligned_angle_error(torus, k) for k in (12, 24, 48)]
    for mesh, u, _, _ in rows:
        assert fvf.singularities(mesh, u, n=4)[0].size == 0
    h = [r[0].mean_edge_length for r in rows]
    err = [r[2] for r in rows]
    assert err[-1] < 1.0 and _rate(h, err) >= 0.9, err


def test_curvature_aligned_cross_field_on_cylinder_is_exact():
    for k in (8, 16):
        mesh, u, worst, _ = _aligned_angle_error(cylinder, k)
        assert worst < 1e-6
        assert fvf.singularities(mesh, u, n=4)[0].size == 0


@pytest.mark.slow
def test_curvature_aligned_cross_field_on_ellipsoid_converges():
    """With a strong alignment (β = 10⁴) the cross field follows the principal directions
    away from the umbilics, and the error falls under refinement."""
    rows = [_aligned_angle_error(ellipsoid, k, 1e4) for k in (3, 4, 5)]
    h = [r[0].mean_edge_length for r in rows]
    mean = [r[3] for r in rows]
    assert mean[-1] < 0.2 and _rate(h, mean) >= 1.0, mean
    mesh, u = rows[-1][0], rows[-1][1]
    ids, ind = fvf.singularities(mesh, u, n=4)
    assert ind.tolist() == [0.5] * 4  # the four umbilics of a triaxial ellipsoid


def test_line_field_alignment_and_odd_n_rejected():
    mesh, grad, hess, project = torus(12)
    u = fvf.design_field(mesh, n=2, align="curvature")
    _, _, d1 = _implicit_principal(project(mesh.face_centroids), grad, hess)
    d1 = mesh.project_tangent(d1)
    err = np.abs(np.angle(fvf.to_power(mesh, u, 2) * np.conj(fvf.to_power(mesh, d1, 2)))) / 2
    assert np.degrees(err).max() < 3.0
    for n in (1, 3):
        with pytest.raises(fvf.DirectionCountError, match="even n"):
            fvf.design_field(mesh, n=n, align="curvature")


def test_transient_estimate_equals_the_cached_one_and_is_not_stored():
    from fvf.mesh.curvature import CACHE_KEY, principal_curvatures_transient

    mesh = fvf.mesh.builtin.spot()
    fresh = principal_curvatures_transient(mesh)
    assert CACHE_KEY not in mesh._cache  # a one-shot design keeps no copy
    cached = fvf.principal_curvatures(mesh)
    for name in ("k1", "k2", "d1", "d2", "shape_operator"):
        assert np.array_equal(getattr(fresh, name), getattr(cached, name))
    assert principal_curvatures_transient(mesh) is cached  # the cache when it is there


def test_curvature_aligned_design_keeps_no_curvature_on_the_mesh():
    mesh = fvf.mesh.builtin.spot()
    u = fvf.design_field(mesh, n=4, align="curvature")
    assert "principal_curvatures" not in mesh._cache
    assert np.isfinite(u).all()
