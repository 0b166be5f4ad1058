"""Bad input: every error is a typed ValueError naming the indices and a fix."""

import numpy as np
import pytest

import fvf


def tet():
    X = np.array([[1.0, 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1]])
    F = np.array([[0, 1, 2], [0, 2, 3], [0, 3, 1], [1, 3, 2]])
    return X, F


def test_valid_tetrahedron():
    mesh = fvf.TriMesh(*tet())
    assert mesh.is_closed and mesh.euler_characteristic == 2


@pytest.mark.parametrize(
    "X, F, err, match",
    [
        (np.zeros((4, 2)), tet()[1], fvf.MeshShapeError, r"shape \(n, 3\)"),
        (tet()[0], tet()[1][:, :2], fvf.MeshShapeError, "triangulate"),
        (tet()[0], tet()[1].astype(float), fvf.MeshShapeError, "astype"),
        (tet()[0], np.zeros((0, 3), int), fvf.MeshShapeError, "empty"),
        (tet()[0].astype(str), tet()[1], fvf.MeshShapeError, "real numbers"),
    ],
)
def test_shape_errors(X, F, err, match):
    with pytest.raises(err, match=match):
        fvf.TriMesh(X, F)


def test_nonfinite_vertices_named():
    X, F = tet()
    X[2, 1] = np.nan
    with pytest.raises(fvf.NonFiniteError, match=r"vertices \[2\]"):
        fvf.TriMesh(X, F)


def test_index_out_of_range_named():
    X, F = tet()
    F[3, 1] = 4
    with pytest.raises(fvf.MeshIndexError, match=r"faces \[3\].*0-based"):
        fvf.TriMesh(X, F)
    F[3, 1] = -1
    with pytest.raises(fvf.MeshIndexError, match=r"\[0, 4\)"):
        fvf.TriMesh(X, F)


def test_repeated_vertex_in_face():
    X, F = tet()
    F[1] = [0, 2, 2]
    with pytest.raises(fvf.MeshIndexError, match=r"faces \[1\].*repeat a vertex") as caught:
        fvf.TriMesh(X, F)
    # a degenerate face too: the repairs of degenerate faces (fvf quad FILE, the CLI's
    # `fvf repair` hint) apply to it, as to a zero-area face
    assert isinstance(caught.value, fvf.RepeatedVertexError)
    assert isinstance(caught.value, fvf.DegenerateFaceError)


def test_a_zero_area_stl_facet_welded_shut_is_repaired_by_fvf_quad(tmp_path, capsys):
    """An STL facet whose corners the weld merges names one vertex twice; fvf quad
    repaired zero-area faces but refused this one (exit 2)."""
    from fvf.cli.main import main

    ball = fvf.icosphere(2)
    F = np.vstack([ball.faces, [[0, 1, 1]]])  # the extra facet: two corners at one point
    fvf.write_mesh(tmp_path / "b.obj", ball.vertices, F)
    out = tmp_path / "q.obj"
    assert main(["quad", str(tmp_path / "b.obj"), "--faces", "200", "-o", str(out)]) == 0
    assert "repaired as `fvf repair` does" in capsys.readouterr().err and out.exists()


def test_unreferenced_vertices_and_fix():
    X, F = tet()
    X = np.vstack([X, [[5.0, 5, 5]]])
    with pytest.raises(fvf.UnreferencedVertexError, match=r"\[4\].*remove_unreferenced"):
        fvf.TriMesh(X, F)
    X2, F2, kept = fvf.remove_unreferenced_vertices(X, F)
    assert np.array_equal(kept, [0, 1, 2, 3]) and fvf.TriMesh(X2, F2).n_vertices == 4


def test_zero_area_face():
    X = np.array([[0.0, 0, 0], [1, 0, 0], [2, 0, 0], [0, 1, 0]])
    F = np.array([[0, 1, 3], [1, 2, 3], [0, 2, 1]])  # face 2 is collinear
    with pytest.raises(fvf.DegenerateFaceError, match=r"faces \[2\].*have zero area"):
        fvf.TriMesh(X, F)


def test_non_manifold_edge():
    X = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1]])
    F = np.array([[0, 1, 2], [1, 0, 3], [0, 1, 4]])  # edge (0, 1) in three faces
    with pytest.raises(fvf.NonManifoldError, match=r"\(0, 1\).*more than two faces"):
        fvf.TriMesh(X, F)


def test_duplicated_face_is_reported():
    X, F = tet()
    with pytest.raises((fvf.NonManifoldError, fvf.OrientationError), match="faces"):
        fvf.TriMesh(X, np.vstack([F, F[:1]]))


def test_non_manifold_vertex():
    """Two tetrahedra sharing one vertex (a bowtie of surfaces)."""
    X, F = tet()
    X2 = np.vstack([X, X[1:] + [3.0, 0, 0]])
    X2[0] = [1.0, 1, 1]
    F2 = np.vstack([F, np.where(F == 0, 0, F + 3)])
    with pytest.raises(fvf.NonManifoldError, match=r"vertices \[0\].*are non-manifold"):
        fvf.TriMesh(X2, F2)


def test_inconsistent_orientation_named():
    X, F = tet()
    F[2] = F[2, ::-1]
    with pytest.raises(fvf.OrientationError, match=r"faces \[.*2.*flip"):
        fvf.TriMesh(X, F)


def test_field_errors():
    mesh = fvf.icosphere(1)
    m, n = mesh.n_faces, mesh.n_vertices
    with pytest.raises(fvf.FieldShapeError, match=rf"\({m}, 3\).*vertex field"):
        fvf.D_V(mesh, np.zeros((n, 3)))
    with pytest.raises(fvf.FieldValueError, match=r"NaN.*faces \[5\]"):
        v = np.zeros((m, 3))
        v[5, 0] = np.inf
        fvf.D_F(mesh, v)
    with pytest.raises(fvf.FieldShapeError, match="vertices"):
        fvf.gradient(mesh, np.zeros(n + 1))
    with pytest.raises(fvf.FieldShapeError, match="faces"):
        fvf.Dtilde_dual_F(mesh, np.zeros(n))
    with pytest.raises(fvf.FieldShapeError, match="real numeric"):
        fvf.D_F(mesh, np.full((m, 3), "a"))
    with pytest.raises(ValueError, match="columns"):
        fvf.extract_field(mesh, np.zeros((3, 4)))


def test_non_tangent_field_projected_with_warning():
    mesh = fvf.icosphere(1)
    v = mesh.project_tangent(np.cross([0, 0, 1.0], mesh.face_centroids))
    bumped = v + 0.1 * mesh.face_normals
    with pytest.warns(fvf.NonTangentFieldWarning, match="projected"):
        B1 = fvf.B(mesh, bumped, v)
    assert abs(B1).max() < 1e-14  # computed on the projection, which is v: B(v, v) = 0
    assert abs(fvf.B(mesh, bumped, v, tangent="ignore") - B1).max() > 0
    with pytest.raises(fvf.FieldShapeError, match="project_tangent"):
        fvf.D_V(mesh, bumped, tangent="raise")
    # flattened fields are accepted
    assert abs(fvf.D_F(mesh, v.ravel()) - fvf.D_F(mesh, v)).max() == 0


def test_errors_are_value_errors():
    for cls in (fvf.MeshError, fvf.FieldShapeError, fvf.MeshReadError, fvf.OrientationError):
        assert issubclass(cls, ValueError)
    assert issubclass(fvf.FlowGrowthWarning, fvf.FvfWarning)
