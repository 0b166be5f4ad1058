"""Seamless parameterization and quad meshes: exact seams, closed manifold quads, χ kept."""

from __future__ import annotations

import numpy as np
import pytest

import fvf
from conftest import load_shared
from fvf.design.cancellation import split_large_singularities
from fvf.param.extraction import extract_quads
from fvf.param.quality import quad_topology
from fvf.param.seams import ROTATIONS
from quadcheck import SurfaceDistance


# ---------------------------------------------------------------------------- helpers
def torus_uv(mesh, n1, n2, shift=(0.0, 0.0), R=1.0):
    """The analytic integer-seamless parameterization (n1 θ/2π, n2 φ/2π) per corner."""
    X = mesh.vertices
    th = np.arctan2(X[:, 1], X[:, 0])
    ph = np.arctan2(X[:, 2], np.hypot(X[:, 0], X[:, 1]) - R)
    uv = np.stack([th * n1 / (2 * np.pi), ph * n2 / (2 * np.pi)], axis=1)[mesh.faces]
    period = np.array([n1, n2], dtype=float)
    uv = uv - period * np.round((uv - uv[:, :1]) / period) + np.asarray(shift)
    a, b = uv[:, 1] - uv[:, 0], uv[:, 2] - uv[:, 0]
    if np.median(a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]) < 0:
        uv = uv[..., ::-1]
    return uv


def rounded_cube(subdivisions: int = 4, p: float = 8.0) -> fvf.TriMesh:
    """An icosphere pushed onto the unit ball of the L^p norm: a cube with round edges."""
    s = fvf.icosphere(subdivisions)
    X = s.vertices / (np.abs(s.vertices) ** p).sum(axis=1, keepdims=True) ** (1 / p)
    return fvf.TriMesh(X, s.faces)


def check_closed_quads(mesh, V, Q):
    closed, manifold, chi, valence = quad_topology(V.shape[0], Q)
    assert closed and manifold
    assert chi == mesh.euler_characteristic
    assert np.all(Q[:, 0] != Q[:, 2]) and np.all(Q[:, 1] != Q[:, 3])
    return valence


def check_orientation(mesh, V, Q):
    """Every quad's normal (cross of its diagonals) agrees with the input surface under
    it: the vector area of the input faces whose centroids lie within half the quad's
    shorter diagonal of its centroid, found by brute force, or, when none does, the
    normal at the surface point closest to its centroid, found exactly
    (``quadcheck.SurfaceDistance.normal``; the nearest centroid is not the nearest
    surface next to large triangles: on nefertiti's base it lies on the far side of a
    shelf)."""
    n = np.cross(V[Q[:, 2]] - V[Q[:, 0]], V[Q[:, 3]] - V[Q[:, 1]])
    c = V[Q].mean(axis=1)
    r = 0.5 * np.minimum(
        np.linalg.norm(V[Q[:, 2]] - V[Q[:, 0]], axis=1),
        np.linalg.norm(V[Q[:, 3]] - V[Q[:, 1]], axis=1),
    )
    AN = mesh.face_areas[:, None] * mesh.face_normals
    local = np.zeros_like(n)
    for chunk in np.array_split(np.arange(len(Q)), max(1, len(Q) // 256)):
        d = np.linalg.norm(c[chunk, None] - mesh.face_centroids[None], axis=2)
        local[chunk] = (d <= r[chunk, None]).astype(float) @ AN
    empty = np.flatnonzero(~local.any(axis=1))
    if empty.size:
        h = 0.05 * float(np.median(r))
        local[empty] = SurfaceDistance(mesh.vertices, mesh.faces, h).normal(c[empty])
    assert np.all(np.einsum("qd,qd->q", n, local) > 0)


def check_seamless(mesh, r, tol=1e-9):
    """Across every edge: uv_s = R^q uv_t + c at both ends, c integer; cones on integers."""
    F, E = mesh.faces, mesh.edges
    s, t = r.sides[:, 0], r.sides[:, 1]
    for end in (0, 1):
        v = E[:, end]
        us = r.uv[s, np.argmax(F[s] == v[:, None], axis=1)]
        ut = r.uv[t, np.argmax(F[t] == v[:, None], axis=1)]
        moved = np.einsum("eij,ej->ei", ROTATIONS[r.rotation], ut) + r.translation
        assert np.abs(us - moved).max() < tol
    assert np.abs(r.translation - np.round(r.translation)).max() < tol
    assert not r.translation[~r.cut].any() and not r.rotation[~r.cut].any()
    for v in r.singular:
        corners = r.uv[F == v]
        assert np.abs(corners - np.round(corners)).max() < tol


# ---------------------------------------------------------------------------- extraction
@pytest.mark.parametrize(
    "n1, n2, shift", [(12, 6, (0.3, 0.2)), (48, 24, (0.0, 0.0)), (7, 5, (0.1, 0.7))]
)
def test_torus_analytic_grid_is_extracted_exactly(n1, n2, shift):
    """n1 × n2 regular quads, also when every grid line runs along mesh edges (48 × 24)."""
    mesh = fvf.torus(48, 24)
    qm = extract_quads(mesh, torus_uv(mesh, n1, n2, shift))
    assert qm.quads.shape == (n1 * n2, 4) and qm.vertices.shape == (n1 * n2, 3)
    valence = check_closed_quads(mesh, qm.vertices, qm.quads)
    assert np.all(valence == 4)
    check_orientation(mesh, qm.vertices, qm.quads)
    # vertices sit at the analytic grid angles, up to the chordal (PL) error of the mesh
    X = qm.vertices
    th = np.arctan2(X[:, 1], X[:, 0]) * n1 / (2 * np.pi)
    ph = np.arctan2(X[:, 2], np.hypot(X[:, 0], X[:, 1]) - 1.0) * n2 / (2 * np.pi)
    a, b = th + shift[0], ph + shift[1]
    if np.abs(a - np.round(a)).max() > 0.05:  # the axes were swapped to keep uv positive
        a, b = th + shift[1], ph + shift[0]
    assert np.abs(a - np.round(a)).max() < 5e-3 and np.abs(b - np.round(b)).max() < 5e-3
    assert np.array_equal(qm.vertex_uv, np.round(qm.vertex_uv))


def test_extraction_rejects_broken_uv():
    mesh = fvf.torus(24, 12)
    uv = torus_uv(mesh, 6, 3)
    seam = uv.copy()
    seam[0] += 0.3  # face 0 shifted: not seamless any more
    with pytest.raises(fvf.QuadExtractionError, match="not integer-seamless"):
        extract_quads(mesh, seam)
    flipped = uv.copy()
    flipped[5] = flipped[5, [0, 2, 1]]
    with pytest.raises(fvf.QuadExtractionError, match="flipped"):
        extract_quads(mesh, flipped)
    with pytest.raises(fvf.QuadExtractionError, match="shape"):
        extract_quads(mesh, uv[:-1])
    with pytest.raises(fvf.QuadExtractionError, match="boundary"):
        extract_quads(fvf.disk(4, 6), np.zeros((fvf.disk(4, 6).n_faces, 3, 2)))


# ---------------------------------------------------------------------------- pipeline
def test_torus_curvature_aligned_quads_are_regular():
    mesh = fvf.torus(48, 24)
    V, Q = made = fvf.quad_mesh(mesh, target_faces=300)
    p = made.parameterization
    assert p.singular.size == 0 and p.n_flipped == 0
    valence = check_closed_quads(mesh, V, Q)
    assert np.all(valence == 4)
    check_orientation(mesh, V, Q)
    check_seamless(mesh, p)
    assert abs(Q.shape[0] - 300) <= 0.3 * 300
    q = fvf.quad_quality(mesh, V, Q, parameterization=p)
    assert q.n_irregular == 0 and q.alignment_mean < 5.0 and q.angle_deviation_p95 < 15.0
    assert q.curl_residual < 0.1  # the rescaled principal frame is nearly integrable


def test_rounded_cube_has_eight_valence_three_corners():
    mesh = rounded_cube(4)
    V, Q = made = fvf.quad_mesh(mesh, target_faces=600)
    p = made.parameterization
    valence = check_closed_quads(mesh, V, Q)
    assert sorted(p.index4[p.singular]) == [1] * 8
    assert np.count_nonzero(valence == 3) == 8 and np.all((valence == 3) | (valence == 4))
    check_orientation(mesh, V, Q)
    check_seamless(mesh, p)


def test_sphere_seams_are_exact_and_cones_on_integers():
    mesh = fvf.icosphere(3)
    p = fvf.seamless_parameterization(mesh, target_faces=400)
    assert p.n_flipped == 0 and p.cut.any()
    assert np.sum(p.index4) == 4 * mesh.euler_characteristic
    check_seamless(mesh, p)


@pytest.mark.parametrize("target", [150, 600])
def test_quad_count_follows_the_target(target):
    mesh = fvf.torus(48, 24)
    V, Q = fvf.quad_mesh(mesh, target_faces=target)
    assert abs(Q.shape[0] - target) <= 0.3 * target
    mesh = fvf.icosphere(3)
    V, Q = fvf.quad_mesh(mesh, target_faces=target // 2)
    assert abs(Q.shape[0] - target // 2) <= 0.3 * (target // 2)


def test_user_field_is_followed():
    """A field rotated by 45° on the torus gives quads along the rotated directions."""
    mesh = fvf.torus(48, 24)
    u = fvf.param.default_cross_field(mesh)
    rot = mesh.from_complex(mesh.to_complex(u) * np.exp(0.25j * np.pi))
    V, Q = fvf.quad_mesh(mesh, field=rot, target_faces=400)
    check_closed_quads(mesh, V, Q)
    q_rot = fvf.quad_quality(mesh, V, Q, field=rot)
    q_orig = fvf.quad_quality(mesh, V, Q, field=u)
    assert q_rot.alignment_mean < 10.0 < q_orig.alignment_mean


# ---------------------------------------------------------------------------- bad input
def test_meshes_with_boundary_are_meshed_with_their_boundary():
    """A disk: the quads have one boundary loop and χ = 1, counted from the connectivity."""
    mesh = fvf.disk(8, 24)
    V, Q = fvf.quad_mesh(mesh, target_faces=100)
    closed, manifold, chi, _ = fvf.param.quality.quad_topology(V.shape[0], Q)
    assert manifold and not closed and chi == 1
    e = np.sort(np.stack([Q, np.roll(Q, -1, axis=1)], axis=2).reshape(-1, 2), axis=1)
    edges, count = np.unique(e, axis=0, return_counts=True)
    rim = np.unique(edges[count == 1])
    b = mesh.edges[mesh.boundary_edges]  # the 24-gon's sides
    A, B = mesh.vertices[b[:, 0]], mesh.vertices[b[:, 1]]
    t = np.clip(np.einsum("rkd,kd->rk", V[rim, None] - A, B - A) / ((B - A) ** 2).sum(1), 0, 1)
    d = np.linalg.norm(A + t[..., None] * (B - A) - V[rim, None], axis=2).min(axis=1)
    assert d.max() < 1e-12  # the quads' boundary vertices lie on the input's boundary


def test_several_components_are_rejected():
    a = fvf.icosphere(1)
    X = np.concatenate([a.vertices, a.vertices + 3.0])
    F = np.concatenate([a.faces, a.faces + a.n_vertices])
    with pytest.raises(fvf.ParameterizationInputError, match="2 components"):
        fvf.seamless_parameterization(fvf.TriMesh(X, F), target_faces=20)


def test_non_orientable_input_is_rejected():
    """A Möbius strip cannot even become a TriMesh (typed OrientationError)."""
    n = 12
    t = np.linspace(0, 2 * np.pi, n, endpoint=False)
    X = []
    for s in (-0.3, 0.3):
        X.append(
            np.stack(
                [
                    (1 + s * np.cos(t / 2)) * np.cos(t),
                    (1 + s * np.cos(t / 2)) * np.sin(t),
                    s * np.sin(t / 2),
                ],
                axis=1,
            )
        )
    X = np.concatenate(X)
    F = []
    for i in range(n):
        j = (i + 1) % n
        a, b, c, d = i, j, n + i, n + j
        if j == 0:  # the half twist swaps the sides
            b, d = n + j, j
        F += [[a, b, d], [a, d, c]]
    with pytest.raises(fvf.MeshError):
        fvf.quad_mesh(fvf.TriMesh(X, np.array(F)), target_faces=10)


def _three_quarter_turn_field():
    """A bipyramid and a cross field turning by 3/4 of a turn around its apex."""
    k = 16
    t = 2 * np.pi * np.arange(k) / k
    ring = np.stack([np.cos(t), np.sin(t), np.zeros(k)], axis=1)
    X = np.concatenate([ring, [[0, 0, 0.3], [0, 0, -0.3]]])
    top = [[i, (i + 1) % k, k] for i in range(k)]
    bottom = [[(i + 1) % k, i, k + 1] for i in range(k)]
    mesh = fvf.TriMesh(X, np.array(top + bottom))
    c = mesh.face_centroids
    theta = np.arctan2(c[:, 1], c[:, 0])
    angle = np.where(c[:, 2] > 0, 0.75 * theta, 0.0)  # absolute angle 3θ/4 on the top fan
    u = mesh.project_tangent(np.stack([np.cos(angle), np.sin(angle), np.zeros_like(angle)], 1))
    return mesh, u


def test_field_with_high_index_singularity_is_rejected_when_kept():
    """With the field's topology kept (no cone editing), index 3/4 is refused."""
    mesh, u = _three_quarter_turn_field()
    ids, ind = fvf.singularities(mesh, u, n=4)
    assert np.abs(ind).max() > 0.5  # the case is not trivial
    with pytest.raises(fvf.ParameterizationInputError, match="index beyond"):
        fvf.seamless_parameterization(mesh, field=u, target_faces=20, cone_cancel_radius=0)


def test_high_index_singularity_is_split():
    """By default a cone beyond ±1/2 is split (index moved off it) before the fit."""
    mesh, u = _three_quarter_turn_field()
    before = np.abs(fvf.singularities(mesh, u, n=4)[1]).max()
    v = split_large_singularities(mesh, u, 4, radius=0.5, max_step=2)
    ids, ind = fvf.singularities(mesh, v, n=4)
    assert before > 0.5 and np.abs(ind).max() <= 0.5
    assert ind.sum() == pytest.approx(mesh.euler_characteristic)


def test_target_too_coarse_for_the_topology():
    with pytest.raises(fvf.QuadExtractionError):
        fvf.quad_mesh(fvf.torus(24, 12), target_faces=1, retry=False)


def test_a_target_too_coarse_is_retried_with_more_quads():
    """The retries end at a valid torus with more quads; the log says what failed first,
    and a warning how many more (the quads sized by curvature, about the tube's radius)."""
    with pytest.warns(fvf.QuadCountRaisedWarning, match="sized by curvature"):
        r = fvf.quad_mesh(fvf.torus(24, 12), target_faces=1)
    assert r.validity.valid and r.quads.shape[0] > 1
    assert "too coarse" in r.attempts[0] and r.attempts[-1].endswith(f"valid, {len(r.quads)} quads")


@pytest.mark.parametrize(
    "kwargs",
    [
        {"target_faces": 0},
        {"target_faces": 2.5},
        {"edge_length": -1.0},
        {"target_faces": 10, "edge_length": 0.1},
        {"align": "nope"},
    ],
)
def test_bad_parameters(kwargs):
    with pytest.raises(fvf.ParameterError):
        fvf.seamless_parameterization(fvf.icosphere(2), **kwargs)


def test_zero_field_is_rejected():
    mesh = fvf.icosphere(2)
    with pytest.raises(fvf.FieldValueError, match="zero on faces"):
        fvf.seamless_parameterization(mesh, field=np.zeros((mesh.n_faces, 3)))


# ---------------------------------------------------------------------------- shared meshes
CONES_FORCED_BY_THE_GEOMETRY = pytest.mark.xfail(
    reason="hands and feet narrower than one quad edge carry 1.5-1.7 x 2 pi of curvature: "
    "clusters of cones closer than one quad edge, whose rounding folds the uv triangles "
    "between them, on every attempt; see docs/quads.md",
    strict=True,
)
STRICTER_GATE = pytest.mark.xfail(
    reason="since the validity gate rejects quads with no diagonal split facing the surface "
    "and the sharp-edge features hold the field, these fail every attempt (measured: the "
    "knight's uv flips at the facets' features, the lion's folded quads)",
    strict=False,
)
SHARED_CASES = [
    ("3holes.off", 1500),
    ("bob_tri.obj", 1500),
    ("spot.obj", 1500),
    ("fertility.off", 1500),
    ("rocker-arm.obj", 3000),
    ("armadillo.obj", 8000),
    pytest.param("faust_r_tr_reg_001.off", 2499, marks=CONES_FORCED_BY_THE_GEOMETRY),
    pytest.param("faust_r_tr_reg_001.off", 20000, marks=STRICTER_GATE),  # 2 quads per triangle
    pytest.param("decimated-knight.off", 400, marks=STRICTER_GATE),
    ("nefertiti.obj", 24984),
    pytest.param("lion-00.off", 2499, marks=STRICTER_GATE),
]


@pytest.mark.slow
@pytest.mark.parametrize("name, target", SHARED_CASES)
def test_shared_meshes_no_flips_and_closed_quads(name, target):
    """A valid mesh (retries allowed: the attempts say which one made it), its
    parameterizations seamless and unflipped, counted again here."""
    mesh = load_shared(name)
    V, Q = made = fvf.quad_mesh(mesh, target_faces=target)
    for p, surface in zip(made.parameterizations, made.surfaces, strict=True):
        assert p.n_flipped == 0
        check_seamless(surface, p)
    check_closed_quads(mesh, V, Q)
    check_orientation(mesh, V, Q)
    assert 0.7 * target <= Q.shape[0] <= 1.3 * 2.25 * target


@pytest.mark.slow
def test_faust_at_2499_quads_is_a_typed_error_listing_every_attempt():
    """Cones forced by the fingers fold the uv triangles at this size on every attempt
    (remeshed, the other field, sized by curvature on the input and remeshed, 1.5x and
    2.25x the quads): a QuadMeshError says so."""
    mesh = load_shared("faust_r_tr_reg_001.off")
    with pytest.raises(fvf.QuadMeshError) as info:
        fvf.quad_mesh(mesh, target_faces=2499)
    assert len(info.value.attempts) == 8
    assert sum("sized by curvature" in a for a in info.value.attempts) == 4
    assert all("flipped" in a or "folded" in a for a in info.value.attempts)


@pytest.mark.slow
@pytest.mark.perf
def test_fold_repair_stops_when_the_weights_run_away(monkeypatch):
    """On FAUST the first re-rounding of the stiffened fit leaves more flipped triangles
    than the 138 the repair started from (``uv_folds.WORSE_FLOOR``; before that rule it
    went on to the third, which left more than RUNAWAY_FACTOR x the fewest + RUNAWAY_SLACK,
    with the same best): the repair stops there, 6 re-roundings early, and reports the
    best it saw."""
    from fvf.param import uv_folds as folds

    mesh = load_shared("faust_r_tr_reg_001.off")
    solvers, released = [], []
    real = folds.MixedIntegerSolver
    monkeypatch.setattr(folds, "MixedIntegerSolver", lambda *a: solvers.append(1) or real(*a))
    release = real.release
    monkeypatch.setattr(real, "release", lambda self: released.append(1) or release(self))
    with pytest.raises(fvf.QuadExtractionError, match=r"\(121 in all\)"):
        with pytest.warns(fvf.FlippedParameterizationWarning):
            fvf.quad_mesh(mesh, target_faces=2499, retry=False, crease_angle=None)
    assert len(solvers) == 1  # of 7 possible re-roundings
    assert len(released) == 1  # each factorization freed before the next is made


@pytest.mark.slow
def test_smoothest_field_of_a_body_scan_has_no_cone_beyond_a_half():
    """FAUST's smoothest cross field is ~1e-10 of its maximum on some faces; the turnings
    around one vertex sum to index -3/4 there. The cone is split, not refused."""
    mesh = load_shared("faust_r_tr_reg_001.off")
    ids, ind = fvf.singularities(mesh, fvf.param.default_cross_field(mesh, "smooth"), n=4)
    assert ind.min() == -0.75  # the case is not trivial
    with pytest.warns(fvf.FlippedParameterizationWarning):
        p = fvf.seamless_parameterization(mesh, target_faces=2499, align="smooth")
    assert np.abs(p.index4).max() <= 2
    assert p.index4.sum() == 4 * mesh.euler_characteristic
    check_seamless(mesh, p)


# ---------------------------------------------------------------------------- symmetry
def test_symmetric_field_gives_nearly_symmetric_quads():
    """A mirror-symmetric peanut: the symmetrized field's quads map onto themselves."""
    from scipy.spatial import cKDTree

    s = fvf.icosphere(4)
    X = s.vertices
    w = 0.6 + 0.5 * X[:, 0] ** 2
    Y = np.stack([1.6 * X[:, 0], X[:, 1] * w, X[:, 2] * w + 0.2 * X[:, 1]], axis=1)
    mesh = fvf.TriMesh(Y, s.faces)

    def mirror(P):
        return P * np.array([-1.0, 1.0, 1.0])

    d, pi = cKDTree(Y).query(mirror(Y))
    assert d.max() < 1e-12  # the triangulation is exactly symmetric
    # the default field of a symmetric mesh is already nearly symmetric: turn it by an
    # angle that the mirror (orientation-reversing) does not preserve
    u0 = fvf.param.default_cross_field(mesh)
    theta = 0.35 + 0.3 * mesh.face_centroids[:, 0]
    u = np.cos(theta)[:, None] * u0 + np.sin(theta)[:, None] * np.cross(mesh.face_normals, u0)
    sym = fvf.symmetrize_cross_field(mesh, u, pi)
    V, Q = fvf.quad_mesh(mesh, target_faces=800, field=sym)
    check_closed_quads(mesh, V, Q)
    median, worst = fvf.quad_symmetry_error(V, Q, mirror)
    assert median < 0.02 and worst < 0.1
    V0, Q0 = fvf.quad_mesh(mesh, target_faces=800, field=u)
    assert fvf.quad_symmetry_error(V0, Q0, mirror)[0] > 5 * median  # the plain field is not
    with pytest.raises(fvf.ParameterError, match="permutation"):
        fvf.symmetrize_cross_field(mesh, u, pi[:-1])


# ---------------------------------------------------------------------------- files and command
def test_quad_and_uv_files_round_trip(tmp_path):
    from fvf.io.meshfile import read_quad_mesh, write_quad_mesh, write_uv_mesh

    mesh = fvf.torus(24, 12)
    qm = extract_quads(mesh, torus_uv(mesh, 6, 3, (0.25, 0.5)))
    for suffix in (".obj", ".off"):
        path = tmp_path / f"q{suffix}"
        write_quad_mesh(path, qm.vertices, qm.quads)
        V, Q = read_quad_mesh(path)
        assert np.array_equal(V, qm.vertices) and np.array_equal(Q, qm.quads)
    uv_path = tmp_path / "uv.obj"
    uv = torus_uv(mesh, 6, 3)
    write_uv_mesh(uv_path, mesh.vertices, mesh.faces, uv)
    text = uv_path.read_text().splitlines()
    vt = np.array([[float(x) for x in t.split()[1:]] for t in text if t.startswith("vt ")])
    faces = [t.split()[1:] for t in text if t.startswith("f ")]
    assert len(faces) == mesh.n_faces
    corner = np.array([[int(c.split("/")[1]) - 1 for c in f] for f in faces])
    assert np.array_equal(vt[corner], uv)  # every corner's (u, v), exactly
    tri = tmp_path / "t.obj"
    fvf.write_mesh(tri, mesh.vertices, mesh.faces)
    with pytest.raises(fvf.MeshReadError, match="non-quads"):
        read_quad_mesh(tri)
    with pytest.raises(fvf.FvfError, match=".obj or .off"):
        write_quad_mesh(tmp_path / "q.ply", qm.vertices, qm.quads)


def test_command_quad(tmp_path, capsys, monkeypatch):
    from fvf.cli.main import main

    src = tmp_path / "torus.obj"
    fvf.write_mesh(src, fvf.torus(24, 12).vertices, fvf.torus(24, 12).faces)
    out, uv = tmp_path / "q.obj", tmp_path / "uv.obj"
    assert main(["quad", str(src), "--faces", "60", "-o", str(out), "--uv", str(uv)]) == 0
    captured = capsys.readouterr()
    assert "quad extraction" in captured.err and "wrote" in captured.out
    V, Q = fvf.io.read_quad_mesh(out)
    check_closed_quads(fvf.torus(24, 12), V, Q)
    assert uv.read_text().count("\nvt ") > 0
    disk = tmp_path / "disk.obj"  # an open surface keeps its boundary loop
    fvf.write_mesh(disk, fvf.disk(8, 24).vertices, fvf.disk(8, 24).faces)
    assert main(["quad", str(disk), "--faces", "60", "-o", str(tmp_path / "d.obj")]) == 0
    V, Q = fvf.io.read_quad_mesh(tmp_path / "d.obj")
    assert fvf.param.quality.quad_topology(V.shape[0], Q)[2] == 1
    # no attempt passes the gate: exit 4, the error lists the attempts, nothing written
    from fvf.param import quadmesh
    from fvf.param.quad_validity import QuadValidity

    bad = QuadValidity(False, ("planted",), np.empty(0, np.int64), np.nan)
    monkeypatch.setattr(quadmesh, "check_quad_mesh", lambda *a, **k: bad)
    capsys.readouterr()
    assert main(["quad", str(src), "--faces", "60", "-o", str(tmp_path / "t.obj")]) == 4
    err = capsys.readouterr().err
    assert "QuadMeshError" in err and "planted" in err
    assert not (tmp_path / "t.obj").exists()


def test_command_renders_quad_meshes(tmp_path):
    pytest.importorskip("matplotlib")
    from fvf.cli.main import main

    mesh = fvf.torus(24, 12)
    qm = extract_quads(mesh, torus_uv(mesh, 8, 4))
    path = tmp_path / "q.obj"
    fvf.io.write_quad_mesh(path, qm.vertices, qm.quads)
    png = tmp_path / "q.png"
    args = ["render", str(path), "-o", str(png), "--backend", "matplotlib", "--size", "160", "120"]
    assert main(args) == 0
    assert png.stat().st_size > 0


# ---------------------------------------------------------------------------- rounding, folds
def _greedy_by_resolving(S, r, batch):
    """Reference greedy rounding: a new solve of the free unknowns after every batch."""
    k = r.size
    values = np.linalg.solve(S, r)
    fixed = np.zeros(k, dtype=bool)
    while not fixed.all():
        left = np.flatnonzero(~fixed)
        dist = np.abs(values[left] - np.round(values[left]))
        count = max(1, int(np.ceil(batch * left.size)))
        pick = np.union1d(left[np.argsort(dist, kind="stable")[:count]], left[dist < 1e-6])
        values[pick] = np.round(values[pick])
        fixed[pick] = True
        left = np.flatnonzero(~fixed)
        if left.size:
            done = np.flatnonzero(fixed)
            rhs = r[left] - S[np.ix_(left, done)] @ values[done]
            values[left] = np.linalg.solve(S[np.ix_(left, left)], rhs)
    return values


@pytest.mark.parametrize("batch", [0.05, 0.3, 1.0])
def test_greedy_round_matches_re_solving(batch):
    """The conditional-mean updates of greedy_round equal a re-solve after every batch."""
    from fvf.param.rounding import greedy_round

    rng = np.random.default_rng(3)
    M = rng.standard_normal((40, 40))
    S = M @ M.T + 5 * np.eye(40)
    r = 4 * rng.standard_normal(40)
    x = greedy_round(S, r, batch)
    np.testing.assert_array_equal(x, _greedy_by_resolving(S, r, batch))
    assert np.array_equal(x, np.round(x))
    if batch == 1.0:
        np.testing.assert_array_equal(x, np.round(np.linalg.solve(S, r)))


def test_fold_repair_removes_the_flips_of_rounding_on_spot():
    mesh = fvf.spot()
    with pytest.warns(fvf.FlippedParameterizationWarning):
        raw = fvf.seamless_parameterization(mesh, target_faces=1464, stiffening_iterations=0)
    assert raw.n_flipped > 0  # the case is not trivial
    p = fvf.seamless_parameterization(mesh, target_faces=1464)
    assert p.n_flipped == 0
    check_seamless(mesh, p)


# ---------------------------------------------------------------------------- frames, cut mesh
def test_commuting_scaling_gives_a_seamless_unflipped_parameterization():
    from fvf.param.cutmesh import cut_mesh
    from fvf.param.frame_field import commuting_scale

    mesh = fvf.torus(48, 24)
    p = fvf.seamless_parameterization(mesh, target_faces=300, scaling="commuting")
    assert p.n_flipped == 0
    check_seamless(mesh, p)
    sc = p.info["scale"]
    np.testing.assert_allclose(sc, commuting_scale(mesh, cut_mesh(mesh, p.field)))
    A = mesh.face_areas
    assert np.sum(A * sc[:, 0] * sc[:, 1]) == pytest.approx(A.sum())  # same quad count
    with pytest.raises(fvf.ParameterError, match="scaling"):
        fvf.seamless_parameterization(mesh, target_faces=300, scaling="bracket")


def test_cut_mesh_is_combed_off_the_cut_and_cut_to_a_disk():
    from fvf.param.cutmesh import cut_mesh

    mesh = fvf.torus(32, 16)
    cm = cut_mesh(mesh, fvf.param.default_cross_field(mesh, align="smooth"))
    assert not fvf.period_jumps(mesh, cm.field, 4)[~cm.cut].any()
    assert np.array_equal(cm.jumps[cm.cut] != 0, fvf.period_jumps(mesh, cm.field, 4)[cm.cut] != 0)
    assert cm.index4.sum() == 4 * mesh.euler_characteristic
    # the cut mesh is a disk: χ(wedges, faces, cut-doubled edges) = 1
    n_edges = mesh.n_edges + int(cm.cut.sum())
    assert cm.n_wedges - n_edges + mesh.n_faces == 1
