"""The fvf command, run as a user would (a subprocess)."""

import subprocess
import sys


def run(*args, cwd=None):
    return subprocess.run(
        [sys.executable, "-m", "fvf.cli", *args], capture_output=True, text=True, cwd=cwd
    )


def test_info_reports_every_problem(tmp_path):
    from conftest import shared_mesh_path

    r = run("info", str(shared_mesh_path("stanford-bunny.obj")))
    assert r.returncode == 1
    assert "unreferenced_vertices: 1113" in r.stdout and "boundary_loops: 5" in r.stdout
    assert "needle_faces: 1" in r.stdout and "remove_unreferenced_vertices" in r.stdout
    r = run("info", str(shared_mesh_path("fertility.off")))
    assert r.returncode == 0 and "genus: 4" in r.stdout and "no problems found" in r.stdout


def test_a_mesh_fvf_repair_fixes_is_refused_naming_the_repair_command(tmp_path):
    """A scan with vertices left over after holes were cut: `fvf design` refuses it (exit
    2, nothing written) and says which command fixes it; after that command it runs.
    `fvf quad` makes its quads from the faces and says it left the vertices out."""
    import fvf

    ico = fvf.icosphere(3)
    keep = ico.face_centroids[:, 2] < 0.5  # a cap cut off, its vertices left in the file
    src, fixed = tmp_path / "bowl.obj", tmp_path / "bowl_fixed.obj"
    out, quads = tmp_path / "d.npz", tmp_path / "q.obj"
    fvf.write_mesh(src, ico.vertices, ico.faces[keep])
    r = run("design", str(src), "-o", str(out))
    assert r.returncode == 2 and not out.exists()
    assert f"fvf repair {src} -o bowl_fixed.obj" in r.stderr
    assert run("repair", str(src), "-o", str(fixed)).returncode == 0
    assert run("design", str(fixed), "-o", str(out)).returncode == 0
    r = run("quad", str(src), "--faces", "300", "-o", str(quads))
    left_out = int((~np.isin(np.arange(ico.n_vertices), ico.faces[keep])).sum())
    assert r.returncode == 0 and f"{left_out} vertices of {src} belong to no face" in r.stderr


def test_mesh_report_on_broken_meshes():
    import numpy as np

    from fvf.mesh.diagnostics import mesh_report

    X = np.array([[1.0, 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1], [9, 9, 9]])
    F = np.array([[0, 1, 2], [0, 2, 3], [0, 3, 1], [1, 3, 2]])
    flipped = F.copy()
    flipped[2] = flipped[2, ::-1]
    rep = mesh_report(X, flipped)
    assert not rep["ok"] and rep["unreferenced_vertices"] == 1
    assert any("OrientationError" in p for p in rep["problems"])
    assert any("Unreferenced" in p for p in rep["problems"])
    rep = mesh_report(X[:4], F[:, :2])
    assert rep["problems"] and "MeshShapeError" in rep["problems"][0]
    rep = mesh_report(X[:4], F)
    assert rep["ok"] and rep["genus"] == 0 and rep["problems"] == []


# ---------------------------------------------------------------------------- users' data
import numpy as np  # noqa: E402
import pytest  # noqa: E402

import fvf  # noqa: E402
from fvf.cli.main import main  # noqa: E402
from fvf.io.datafile import DataFileError, DataKeyError, MeshMismatchError, read_data  # noqa: E402

COMMANDS = ["demo", "info", "flow", "bracket", "transport", "design", "render", "view"]


@pytest.fixture(scope="module")
def work(tmp_path_factory):
    """A folder with an icosphere (162 vertices, 320 faces) as OBJ and data files on it."""
    d = tmp_path_factory.mktemp("cli")
    mesh = fvf.icosphere(2)
    fvf.write_mesh(d / "ico.obj", mesh.vertices, mesh.faces)
    X, C = mesh.vertices, mesh.face_centroids
    v = mesh.project_tangent(np.cross([0, 0, 1.0], C))  # rotation about z
    u = mesh.project_tangent(np.cross([1.0, 0, 0], C))  # rotation about x
    f = X[:, 0] + X[:, 1] * X[:, 2]
    np.savez(d / "fields.npz", f=f, v=v, u=u, vertices=X, faces=mesh.faces)
    np.savez(d / "two.npz", f=np.stack([f, X[:, 2]], axis=1), v=v, u=u, u1=-u, t=[0.0, 0.4])
    return d, mesh, {"f": f, "v": v, "u": u}


def one_line_error(err: str) -> bool:
    lines = err.strip().splitlines()
    return len(lines) == 1 and lines[0].startswith("fvf") and "Traceback" not in err


def test_flow_subprocess_equals_library(work):
    d, mesh, a = work
    r = run("flow", "ico.obj", "fields.npz", "--t", "0", "0.5", "-1", "-o", "out/flow", cwd=d)
    assert r.returncode == 0, r.stderr
    out = np.load(d / "out" / "flow.npz")
    expected = fvf.flow(mesh, a["v"], a["f"], [0.0, 0.5, -1.0])
    assert out["f_t"].shape == (3, 162)
    np.testing.assert_allclose(out["f_t"], expected, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(out["t"], [0.0, 0.5, -1.0])
    assert str(out["method"]) == "chapter" and str(out["fvf_version"]) == fvf.__version__
    assert str(out["command"]).startswith("fvf flow ico.obj fields.npz --t 0 0.5 -1")
    assert str(out["mesh_path"]) == str((d / "ico.obj").resolve())
    assert list(out["inputs"]) == [str((d / "fields.npz").resolve())]
    np.testing.assert_array_equal(out["faces"], mesh.faces)


def test_flow_methods_and_function_rows_in_process(work, capsys):
    d, mesh, a = work
    out = d / "flow_up.npz"
    assert main(["flow", str(d / "ico.obj"), str(d / "two.npz"), "--method", "upwind",
                 "-o", str(out)]) == 0  # fmt: skip
    res = np.load(out)
    F = np.stack([a["f"], mesh.vertices[:, 2]], axis=1)
    assert res["f_t"].shape == (2, 162, 2)  # (T, n, k): times from the file's key t
    expected = fvf.flow(mesh, a["v"], F, [0.0, 0.4], method="upwind")  # (T, n, k)
    np.testing.assert_allclose(res["f_t"], expected, atol=1e-12)
    assert main(["flow", str(d / "ico.obj"), str(d / "fields.npz"), "--t", "0.3",
                 "--method", "spectral", "--k", "20", "-o", str(out)]) == 0  # fmt: skip
    expected = fvf.flow(mesh, a["v"], a["f"], [0.3], method="spectral", k=20)
    np.testing.assert_allclose(np.load(out)["f_t"], expected, atol=1e-10)
    assert "wrote" in capsys.readouterr().out


def test_negative_values_in_scientific_notation_are_values(work, capsys):
    """-1e-3 and -inf after an option are values, not unknown options: argparse's own
    pattern takes only -1 and -.5 (``--t 0 -1e-2`` was "expected at least one argument",
    ``--t -inf`` too instead of the check of the times)."""
    from fvf.cli.main import parser

    args = parser().parse_args(["render", "m.obj", "--clim", "-1e-3", "1E+2", "-o", "x.png"])
    assert args.clim == [-1e-3, 100.0]
    d, mesh, a = work
    out = d / "flow_neg.npz"
    assert main(["flow", str(d / "ico.obj"), str(d / "fields.npz"), "--t", "0", "-1e-2",
                 "-o", str(out)]) == 0  # fmt: skip
    np.testing.assert_allclose(np.load(out)["f_t"], fvf.flow(mesh, a["v"], a["f"], [0.0, -1e-2]))
    capsys.readouterr()
    assert main(["flow", str(d / "ico.obj"), str(d / "fields.npz"), "--t", "-inf",
                 "-o", str(out)]) == 2  # fmt: skip
    err = capsys.readouterr().err
    assert one_line_error(err) and "finite" in err and "-inf" in err, err


def test_a_non_orientable_file_is_not_sent_to_repair(tmp_path, capsys):
    """A Moebius strip: the error says no repair fixes it and does not point to ``fvf
    repair`` (it did: "`fvf repair ...` fixes it"), and ``fvf info`` prints no fix line;
    faces merely flipped still point to it."""
    n, w = 24, 3
    t = np.linspace(0, 2 * np.pi, n, endpoint=False)
    s = np.linspace(-0.3, 0.3, w)
    V = np.array([[(1 + b * np.cos(a / 2)) * np.cos(a), (1 + b * np.cos(a / 2)) * np.sin(a),
                   b * np.sin(a / 2)] for a in t for b in s])  # fmt: skip
    F = []
    for i in range(n):
        for j in range(w - 1):
            a, b = i * w + j, i * w + j + 1
            c, d = ((i + 1) * w + j, (i + 1) * w + j + 1) if i < n - 1 else (w - 1 - j, w - 2 - j)
            F += [[a, c, b], [b, c, d]]
    path = tmp_path / "strip.obj"
    fvf.write_mesh(path, V, np.array(F))
    assert main(["quad", str(path), "--faces", "100", "-o", str(tmp_path / "q.obj")]) == 2
    err = capsys.readouterr().err
    assert one_line_error(err) and "NonOrientableError" in err and "fvf repair" not in err, err
    assert main(["info", str(path)]) == 1  # problems found
    out = capsys.readouterr().out
    assert "non-orientable" in out and "fix: fvf repair" not in out, out
    ball = fvf.icosphere(1)
    G = ball.faces.copy()
    G[::5] = G[::5, ::-1]
    fvf.write_mesh(tmp_path / "flipped.obj", ball.vertices, G)
    assert (
        main(
            ["quad", str(tmp_path / "flipped.obj"), "--faces", "100", "-o", str(tmp_path / "q.obj")]
        )
        == 2
    )
    assert "fvf repair" in capsys.readouterr().err


def test_bracket_subprocess_equals_library(work):
    d, mesh, a = work
    r = run("bracket", "ico.obj", "two.npz", "-o", "br.npz", cwd=d)
    assert r.returncode == 0, r.stderr
    out = np.load(d / "br.npz")
    v, u = a["v"], a["u"]
    np.testing.assert_allclose(out["commutator"], fvf.commutator_field(mesh, v, u), atol=1e-12)
    np.testing.assert_allclose(out["bracket_norm"], fvf.bracket_norm(mesh, v, u), atol=1e-12)
    on_faces = mesh.project_tangent(fvf.vertex_to_face(mesh) @ out["commutator"])
    np.testing.assert_allclose(out["commutator_face"], on_faces, atol=1e-12)
    normal = np.einsum("ij,ij->i", out["commutator_face"], mesh.face_normals)
    assert np.abs(normal).max() < 1e-12  # drawable as arrows without a warning
    F = np.stack([a["f"], mesh.vertices[:, 2]], axis=1)
    np.testing.assert_allclose(out["bracket_F_f"], fvf.bracket_F(mesh, v, u) @ F)
    np.testing.assert_allclose(out["bracket_V_f"], fvf.bracket_V(mesh, v, u) @ F)
    # [R_z, R_x] is the rotation about -y (up to sign convention): a non-zero field
    assert np.abs(out["commutator"]).max() > 0.1


def test_transport_subprocess_equals_library(work):
    d, mesh, a = work
    r = run("transport", "ico.obj", "fields.npz", "--t", "0", "0.7", "-o", "tr.npz", cwd=d)
    assert r.returncode == 0, r.stderr
    out = np.load(d / "tr.npz")
    expected = fvf.Ad(mesh, a["v"], a["u"], [0.0, 0.7])
    assert str(out["mode"]) == "Ad" and out["u_t"].shape == (2, 320, 3)
    np.testing.assert_allclose(out["u_t"], expected, atol=1e-10)
    np.testing.assert_allclose(out["u_t"][0], a["u"], atol=1e-12)


def test_transport_interpolation_in_process(work):
    d, mesh, a = work
    out = d / "interp.npz"
    assert main(["transport", str(d / "ico.obj"), str(d / "two.npz"), "--t", "0", ".5", "1",
                 "-o", str(out)]) == 0  # fmt: skip
    res = np.load(out)
    assert str(res["mode"]) == "interpolate"
    expected = fvf.interpolate(mesh, a["v"], a["u"], -a["u"], [0.0, 0.5, 1.0])
    np.testing.assert_allclose(res["u_t"], expected, atol=1e-10)
    np.testing.assert_allclose(res["u_t"][2], -a["u"], atol=1e-12)


def test_design_subprocess_equals_library(work):
    d, mesh, _ = work
    faces, directions = np.array([0, 100, 200]), mesh.face_edge_vectors[[0, 100, 200], 0]
    np.savez(d / "c.npz", constraint_faces=faces, directions=directions)
    r = run("design", "ico.obj", "--constraints", "c.npz", "--soft", "50", "-o", "d.npz", cwd=d)
    assert r.returncode == 0, r.stderr
    out = np.load(d / "d.npz")
    v = fvf.design_field(mesh, faces, directions, weights=50.0)
    np.testing.assert_allclose(out["v"], v, atol=1e-12)
    ids, idx = fvf.singularities(mesh, v)
    np.testing.assert_array_equal(out["singularity_vertices"], ids)
    np.testing.assert_array_equal(out["singularity_indices"], idx)
    assert out["singularity_indices"].sum() == 2  # Poincare-Hopf on the sphere
    np.testing.assert_allclose(out["singularity_positions"], mesh.vertices[ids])
    assert f"singularities: {ids.size}" in r.stdout


def test_design_hard_and_points_in_process(work):
    d, mesh, _ = work
    P = mesh.face_centroids[[5, 60]]
    directions = mesh.face_edge_vectors[[5, 60], 1]
    np.savez(d / "cp.npz", points=P, directions=directions)
    assert main(["design", str(d / "ico.obj"), "--constraints", str(d / "cp.npz"), "--hard",
                 "-o", str(d / "dp.npz")]) == 0  # fmt: skip
    expected = fvf.design_field(mesh, points=P, directions=directions, hard=True)
    np.testing.assert_allclose(np.load(d / "dp.npz")["v"], expected, atol=1e-12)


def viz_render():
    viz = pytest.importorskip("fvf.viz")
    if not hasattr(viz, "render"):
        pytest.skip("fvf.viz.render is not built yet")
    return viz


def test_render_subprocess(work):
    viz_render()
    pytest.importorskip("matplotlib")
    d, mesh, a = work
    np.savez(d / "c1.npz", constraint_faces=[0], directions=mesh.face_edge_vectors[[0], 0])
    assert main(["design", str(d / "ico.obj"), "--constraints", str(d / "c1.npz"),
                 "-o", str(d / "d1.npz")]) == 0  # fmt: skip
    r = run("render", "ico.obj", "d1.npz", "--field", "v", "--singularities", "--size", "320",
            "240", "--backend", "matplotlib", "-o", "field.png", cwd=d)  # fmt: skip
    assert r.returncode == 0, r.stderr
    from PIL import Image

    img = np.asarray(Image.open(d / "field.png").convert("RGB")).astype(float)
    assert img.shape[:2] == (240, 320)
    assert img.std(axis=(0, 1)).max() > 5  # not a blank picture
    assert main(["render", str(d / "ico.obj"), str(d / "fields.npz"), "--function", "f",
                 "--backend", "matplotlib", "-o", str(d / "f.png")]) == 0  # fmt: skip
    assert (d / "f.png").stat().st_size > 1000


def test_flow_png(work, monkeypatch):
    viz_render()
    monkeypatch.setenv("FVF_VIZ_BACKEND", "matplotlib")  # skip polyscope's 2 s start-up probe
    pytest.importorskip("matplotlib")
    d, _, _ = work
    assert main(["flow", str(d / "ico.obj"), str(d / "fields.npz"), "--t", "1", "-o",
                 str(d / "fp.npz"), "--png", str(d / "fp.png")]) == 0  # fmt: skip
    assert (d / "fp.png").stat().st_size > 1000


def test_render_without_viz_is_one_line(work, capsys, monkeypatch):
    d, _, _ = work
    monkeypatch.setitem(sys.modules, "fvf.viz", None)  # import fvf.viz -> ImportError
    monkeypatch.delattr(fvf, "viz", raising=False)
    assert main(["render", str(d / "ico.obj"), "-o", str(d / "x.png")]) == 3
    err = capsys.readouterr().err
    assert one_line_error(err) and "fvf[viz]" in err
    assert main(["flow", str(d / "ico.obj"), str(d / "fields.npz"), "--t", "1", "-o",
                 str(d / "x.npz"), "--png", str(d / "x.png")]) == 3  # fmt: skip
    assert not (d / "x.npz").exists()  # checked before any work


def test_view_without_display_is_one_line(work, capsys, monkeypatch):
    d, _, _ = work
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    assert main(["view", str(d / "ico.obj")]) == 3
    assert one_line_error(capsys.readouterr().err)


@pytest.mark.parametrize("command", COMMANDS)
def test_help_shows_an_example(command, capsys):
    assert main([command, "--help"]) == 0
    out = capsys.readouterr().out
    assert "example:" in out and f"fvf {command}" in out and "exit status" in out


def test_top_level_help_and_usage_errors(work, capsys):
    d, _, _ = work
    assert main(["--help"]) == 0
    out = capsys.readouterr().out
    assert all(c in out for c in COMMANDS) and "exit status" in out
    assert main(["flow", str(d / "ico.obj")]) == 2  # missing arguments
    assert one_line_error(capsys.readouterr().err)
    assert main(["flow", str(d / "ico.obj"), str(d / "fields.npz"), "-o", "x.npz"]) == 2
    err = capsys.readouterr().err  # no --t and no key t
    assert one_line_error(err) and "--t" in err
    assert main(["frobnicate"]) == 2
    assert one_line_error(capsys.readouterr().err)


def write(path, text):
    path.write_text(text)
    return str(path)


def bad_inputs(d, mesh, a):
    """(argv, words expected in the error) for every kind of bad input."""
    ico, fields = str(d / "ico.obj"), str(d / "fields.npz")
    broken = write(d / "broken.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n")
    nonmanifold = write(
        d / "fin.obj",
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 -1 0\nv 0 0 1\nf 1 2 3\nf 2 1 4\nf 1 2 5\n",
    )
    np.savez(d / "nov.npz", f=a["f"], w=a["v"])
    np.savez(d / "shortv.npz", f=a["f"], v=a["v"][:10])
    np.savez(d / "vertexv.npz", f=a["f"], v=mesh.vertices)
    np.savez(d / "fnk.npz", f=np.ones((3, 7)), v=a["v"])
    np.savez(d / "nan.npz", f=np.where(np.arange(162) == 7, np.nan, a["f"]), v=a["v"])
    np.savez(d / "strv.npz", f=a["f"], v=np.array("hello"))
    np.savez(d / "other.npz", f=a["f"], v=a["v"], faces=mesh.faces[:, ::-1])
    write(d / "notnpz.npz", "this is not a zip file")
    flow = ["flow", ico]
    return [
        (["flow", str(d / "missing.obj"), fields, "--t", "1", "-o", "o"], ["missing.obj"]),
        (flow + [str(d / "missing.npz"), "--t", "1", "-o", "o"], ["missing.npz"]),
        (["flow", broken, fields, "--t", "1", "-o", "o"], ["MeshReadError", "line 4"]),
        (["bracket", nonmanifold, fields, "-o", "o"], ["NonManifoldError", "fvf info"]),
        (flow + [str(d / "nov.npz"), "--t", "1", "-o", "o"], ["DataKeyError", "'v'", "f, w"]),
        (flow + [str(d / "shortv.npz"), "--t", "1", "-o", "o"], ["'v'", "(10, 3)", "(320, 3)"]),
        (flow + [str(d / "vertexv.npz"), "--t", "1", "-o", "o"], ["(162, 3)", "per vertex"]),
        (flow + [str(d / "fnk.npz"), "--t", "1", "-o", "o"], ["(3, 7)", "(162, k)"]),
        (flow + [str(d / "nan.npz"), "--t", "1", "-o", "o"], ["NaN", "[7]"]),
        (flow + [str(d / "strv.npz"), "--t", "1", "-o", "o"], ["'v'", "real numbers"]),
        (flow + [str(d / "other.npz"), "--t", "1", "-o", "o"], ["MeshMismatchError", "faces"]),
        (flow + [str(d / "notnpz.npz"), "--t", "1", "-o", "o"], ["DataFileError", ".npz"]),
        (flow + [fields, "--t", "nan", "-o", "o"], ["--t"]),
        (flow + [fields, "--t", "1", "--k", "5", "-o", "o"], ["--k", "spectral"]),
        (
            flow + [fields, "--t", "1", "--method", "upwind", "--growth-limit", "9", "-o", "o"],
            ["--growth-limit"],
        ),  # fmt: skip
        (["transport", ico, fields, "--t", "1", "--to", "zz", "-o", "o"], ["'zz'"]),
        (["transport", ico, str(d / "two.npz"), "--t", "2", "-o", "o"], ["[0, 1]"]),
        (["design", ico, "--constraints", fields, "-o", "o"], ["'constraint_faces'"]),
        (["render", ico, fields, "--function", "f[999]", "-o", "o.png"], ["f", "(162,)"]),
        (["info", broken], ["MeshReadError"]),
    ]


def test_bad_input_gives_one_line_and_status_2(work, capsys):
    d, mesh, a = work
    for argv, words in bad_inputs(d, mesh, a):
        if argv[0] == "render" and not hasattr(pytest.importorskip("fvf.viz"), "render"):
            continue
        status = main(argv)
        err = capsys.readouterr().err
        assert status == 2, (argv, err)
        assert one_line_error(err), (argv, err)
        assert all(w in err for w in words), (argv, words, err)


def test_bad_input_subprocess(work):
    """The installed code path: a real process, exit status 2, one line, no traceback."""
    d, mesh, a = work
    cases = bad_inputs(d, mesh, a)
    for argv, _ in [cases[2]]:  # broken OBJ
        r = run(*argv, cwd=d)
        assert r.returncode == 2 and one_line_error(r.stderr), (argv, r.stderr)
    r = run(*cases[4][0], "--debug", cwd=d)
    assert r.returncode != 0 and "Traceback" in r.stderr and "DataKeyError" in r.stderr


def test_computation_failure_is_status_4(work, capsys, monkeypatch):
    d, _, _ = work

    def overflow(*args, **kwargs):
        raise FloatingPointError("the flow overflowed (growth bound 1e300)")

    monkeypatch.setattr(fvf, "flow", overflow)
    assert main(["flow", str(d / "ico.obj"), str(d / "fields.npz"), "--t", "9", "-o",
                 str(d / "x.npz")]) == 4  # fmt: skip
    assert one_line_error(capsys.readouterr().err)

    class Overflowed:  # a transport whose result went to NaN without raising
        def __init__(self, mesh, v):
            pass

        def __call__(self, u, t):
            return fvf.TransportResult(np.full((t.size,) + u.shape, 1e300), np.full(t.size, np.nan))

    monkeypatch.setattr(fvf, "FieldTransport", Overflowed)
    assert main(["transport", str(d / "ico.obj"), str(d / "fields.npz"), "--t", "9", "-o",
                 str(d / "y.npz")]) == 4  # fmt: skip
    err = capsys.readouterr().err
    assert one_line_error(err) and "'normal_part'" in err and not (d / "y.npz").exists()


def test_warnings_are_one_line_each(work, capsys):
    d, mesh, a = work
    np.savez(d / "normal.npz", f=a["f"], v=a["v"] + mesh.face_normals)
    out = d / "nt.npz"
    assert main(["flow", str(d / "ico.obj"), str(d / "normal.npz"), "--t", "0.2",
                 "-o", str(out)]) == 0  # fmt: skip
    err = capsys.readouterr().err
    assert err.startswith("fvf: warning: NonTangentFieldWarning") and "Traceback" not in err
    assert all(line.startswith("fvf: warning:") for line in err.strip().splitlines())
    np.testing.assert_allclose(np.load(out)["v"], a["v"], atol=1e-12)  # projected


def test_info_json(work, capsys):
    import json

    d, _, _ = work
    assert main(["info", "--json", str(d / "ico.obj")]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["genus"] == 0 and report["closed"] and report["problems"] == []
    fin = write(d / "fin2.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 -1 0\nv 0 0 1\n"
                "f 1 2 3\nf 2 1 4\nf 1 2 5\n")  # fmt: skip
    assert main(["info", fin]) == 1
    assert "NonManifoldError" in capsys.readouterr().out


# ---------------------------------------------------------------------------- fvf.fieldio
PLY = """ply
format ascii 1.0
element vertex 5
property double x
property double y
property double z
property float f
element face 2
property list uchar int vertex_indices
property float vx
property float vy
property float vz
property int label
end_header
0 0 0 1
1 0 0 2
1 1 0 3
0 1 0 4
2 0 0 5
4 0 1 2 3 1 0 0 7
3 1 4 2 0 1 0 8
"""


def test_ply_properties_as_functions_and_fields(tmp_path):
    path = tmp_path / "quad.ply"
    path.write_text(PLY)
    with pytest.warns(fvf.io.meshfile.PolygonTriangulatedWarning):
        mesh = fvf.TriMesh(*fvf.read_mesh(path))
    vertex, face = fvf.io.meshfile.read_ply_properties(path)
    np.testing.assert_array_equal(vertex["f"], [1, 2, 3, 4, 5])
    np.testing.assert_array_equal(face["label"], [7, 7, 8])  # the quad became 2 triangles
    data = read_data(path, mesh)
    np.testing.assert_array_equal(data.field("v", mesh), [[1, 0, 0], [1, 0, 0], [0, 1, 0]])
    np.testing.assert_array_equal(data.functions("f", mesh), [1, 2, 3, 4, 5])
    np.testing.assert_array_equal(data["faces"], mesh.faces)  # the PLY's own mesh, checked:
    with pytest.raises(MeshMismatchError, match="'faces' has shape"):
        read_data(path, fvf.disk(4, 6))
    # the same file in binary: write it with the binary writer's layout plus properties
    header = PLY.split("end_header\n")[0].replace("ascii", "binary_little_endian")
    vert = np.array(
        [(0, 0, 0, 1), (1, 0, 0, 2), (1, 1, 0, 3), (0, 1, 0, 4), (2, 0, 0, 5)],
        dtype=[("x", "<f8"), ("y", "<f8"), ("z", "<f8"), ("f", "<f4")],
    )
    quad = np.array([(4, [0, 1, 2, 3], 1, 0, 0, 7)], dtype=[("k", "u1"), ("i", "<i4", (4,)),
                    ("vx", "<f4"), ("vy", "<f4"), ("vz", "<f4"), ("label", "<i4")])  # fmt: skip
    tri = np.array([(3, [1, 4, 2], 0, 1, 0, 8)], dtype=[("k", "u1"), ("i", "<i4", (3,)),
                   ("vx", "<f4"), ("vy", "<f4"), ("vz", "<f4"), ("label", "<i4")])  # fmt: skip
    binary = tmp_path / "quad_bin.ply"
    binary.write_bytes((header + "end_header\n").encode() + vert.tobytes() + quad.tobytes()
                       + tri.tobytes())  # fmt: skip
    vb, fb = fvf.io.meshfile.read_ply_properties(binary)
    assert vb.keys() == vertex.keys() and fb.keys() == face.keys()
    for k in face:
        np.testing.assert_array_equal(fb[k], face[k])
    with pytest.raises(fvf.MeshReadError, match="only PLY"):
        fvf.io.meshfile.read_ply_properties(tmp_path / "x.obj")


def test_flow_reads_ply_properties(work, tmp_path):
    d, mesh, a = work
    lines = ["ply", "format ascii 1.0", f"element vertex {mesh.n_vertices}"]
    lines += [f"property double {c}" for c in "xyzf"]
    lines += [f"element face {mesh.n_faces}", "property list uchar int vertex_indices"]
    lines += [f"property double v{c}" for c in "xyz"] + ["end_header"]
    lines += [" ".join(f"{x:.17g}" for x in row) for row in np.column_stack([mesh.vertices,
              a["f"]])]  # fmt: skip
    lines += [f"3 {i} {j} {k} " + " ".join(f"{x:.17g}" for x in vec)
              for (i, j, k), vec in zip(mesh.faces, a["v"], strict=True)]  # fmt: skip
    ply = tmp_path / "withdata.ply"
    ply.write_text("\n".join(lines) + "\n")
    assert main(["flow", str(ply), str(ply), "--t", "0.5", "-o", str(tmp_path / "o.npz")]) == 0
    expected = fvf.flow(mesh, a["v"], a["f"], [0.5])
    np.testing.assert_allclose(np.load(tmp_path / "o.npz")["f_t"], expected, atol=1e-12)


def test_data_file_errors_name_key_and_shapes(work, tmp_path):
    d, mesh, a = work
    data = read_data(d / "fields.npz", mesh)
    assert set(data) == {"f", "v", "u", "vertices", "faces"} and "v" in data
    with pytest.raises(DataKeyError, match=r"no key 'g' \(keys present: f, faces, u, v"):
        data.functions("g", mesh)
    with pytest.raises(fvf.FieldShapeError, match=r"key 'f' has shape \(162,\), expected"):
        data.field("f", mesh)
    assert data.select("vertices[3]").shape == (3,) and data.select("vertices[3, -1]").ndim == 0
    with pytest.raises(fvf.FieldShapeError, match=r"outside key 'f' of shape \(162,\)"):
        data.select("f[162]")
    with pytest.raises(DataKeyError, match="KEY"):
        data.select("f[a]")
    moved = fvf.TriMesh(mesh.vertices * 1.001, mesh.faces)
    with pytest.raises(MeshMismatchError, match="'vertices' differs"):
        read_data(d / "fields.npz", moved)
    np.save(tmp_path / "single.npy", a["f"])
    with pytest.raises(DataFileError, match="single array"):
        read_data(tmp_path / "single.npy")
    with pytest.raises(FileNotFoundError):
        read_data(tmp_path / "none.npz")
    for exc in (DataFileError, DataKeyError, MeshMismatchError):
        assert issubclass(exc, fvf.FvfError)


def test_docs_session_runs(tmp_path, monkeypatch, capsys):
    """docs/cli.md's Python block and every `fvf ...` line of its bash block work as shown."""
    import re
    from pathlib import Path

    text = (Path(__file__).resolve().parents[2] / "docs" / "cli.md").read_text()
    (python,) = re.findall(r"```python\n(.*?)```", text, flags=re.S)
    (bash,) = re.findall(r"```bash\n(.*?)```", text, flags=re.S)
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("FVF_VIZ_BACKEND", "matplotlib")
    exec(compile(python, "docs/cli.md", "exec"), {})
    viz = __import__("importlib").util.find_spec("fvf.viz") is not None
    for line in bash.strip().splitlines():
        argv = line.split()[1:]
        if argv[0] == "render" and not viz:
            continue
        assert main(argv) == 0, (line, capsys.readouterr().err)
    out = np.load(tmp_path / "flowed.npz")
    assert out["f_t"].shape == (3, 642) and str(out["method"]) == "skew"
    assert np.load(tmp_path / "designed.npz")["singularity_indices"].sum() == 2


def test_render_and_view_pass_the_options_through(work, monkeypatch, capsys):
    """What fvf.viz receives (recorded by stand-ins; the pictures are tested above)."""
    viz = viz_render()
    d, mesh, a = work
    calls = []
    monkeypatch.setattr(viz, "render", lambda mesh, path, **kw: calls.append((path, kw)))
    monkeypatch.setattr(viz, "view", lambda mesh, **kw: calls.append((None, kw)))
    argv = [str(d / "ico.obj"), str(d / "fields.npz"), "--function", "f", "--field", "u",
            "--singularities"]  # fmt: skip
    options = "--clim -1 2 --size 300 200 --view 30 10 --arrow-scale 0.5 --cmap magma -o p.png"
    assert main(["render", *argv, *options.split()]) == 0
    assert main(["view", *argv]) == 0
    (path, kw), (_, kw_view) = calls
    assert path == "p.png" and kw["clim"] == (-1.0, 2.0) and kw["size"] == (300, 200)
    assert kw["view"] == (30.0, 10.0) and kw["arrow_scale"] == 0.5 and kw["cmap"] == "magma"
    np.testing.assert_array_equal(kw["function"], a["f"])
    np.testing.assert_allclose(kw["field"], a["u"])
    ids, idx = fvf.singularities(mesh, a["u"])  # rotation about x: +1 at both poles
    np.testing.assert_array_equal(kw["singularities"][1], idx)
    np.testing.assert_allclose(kw["singularities"][0], mesh.vertices[ids])
    assert idx.tolist() == [1, 1]
    assert kw_view.keys() == {"function", "field", "singularities"}
    assert kw["title"] == "ico.obj, fields.npz"  # named after its files unless --title
    calls.clear()
    assert main(["render", *argv, "--title", "mine", "-o", "q.png"]) == 0
    assert calls[0][1]["title"] == "mine"


def test_several_data_files_are_merged(work, capsys):
    """A designed field from one file and functions from another; later keys win."""
    d, mesh, a = work
    np.savez(d / "c2.npz", constraint_faces=[3], directions=mesh.face_edge_vectors[[3], 0])
    assert main(["design", str(d / "ico.obj"), "--constraints", str(d / "c2.npz"), "-o",
                 str(d / "d2.npz")]) == 0  # fmt: skip
    designed = np.load(d / "d2.npz")["v"]
    out = d / "merged.npz"
    assert main(["flow", str(d / "ico.obj"), str(d / "fields.npz"), str(d / "d2.npz"),
                 "--t", "0.5", "-o", str(out)]) == 0  # fmt: skip
    res = np.load(out)
    np.testing.assert_allclose(res["f_t"], fvf.flow(mesh, designed, a["f"], [0.5]), atol=1e-12)
    assert len(res["inputs"]) == 2
    capsys.readouterr()
    np.savez(d / "bad_f.npz", f=np.zeros(5))
    assert main(["flow", str(d / "ico.obj"), str(d / "d2.npz"), str(d / "bad_f.npz"),
                 "--t", "1", "-o", str(out)]) == 2  # fmt: skip
    err = capsys.readouterr().err  # the message names the file the bad key came from
    assert one_line_error(err) and "bad_f.npz: key 'f' has shape (5,)" in err


def test_flow_that_grew_exits_6_and_names_the_cli_options(tmp_path, capsys):
    """A compressible chapter flow that blows up is written but never reported as
    success: exit status 6, and the advice names the command's options."""
    from conftest import shared_mesh_path

    mesh, v, f0 = fvf.examples.compressible_case(
        fvf.TriMesh(*fvf.read_mesh(shared_mesh_path("lion-00.off")))
    )
    fvf.write_mesh(tmp_path / "lion.off", mesh.vertices, mesh.faces)
    np.savez(tmp_path / "data.npz", f=f0, v=v)
    args = ["flow", str(tmp_path / "lion.off"), str(tmp_path / "data.npz"), "--t", "0.05"]
    status = main([*args, "-o", str(tmp_path / "grew.npz")])
    err = capsys.readouterr().err
    assert status == 6 and (tmp_path / "grew.npz").exists()
    assert "--growth-limit inf" in err and "--method upwind" in err and "np.inf" not in err
    assert main([*args, "--growth-limit", "inf", "-o", str(tmp_path / "ok.npz")]) == 0
    assert main([*args, "--method", "upwind", "-o", str(tmp_path / "up.npz")]) == 0


def test_python_dash_m_fvf_is_the_command():
    """`python -m fvf` runs the same command as `fvf` and `python -m fvf.cli`."""
    r = subprocess.run([sys.executable, "-m", "fvf", "--help"], capture_output=True, text=True)
    assert r.returncode == 0 and "usage: fvf" in r.stdout and "quad" in r.stdout, r.stderr
    bad = subprocess.run([sys.executable, "-m", "fvf", "nosuch"], capture_output=True, text=True)
    assert bad.returncode == 2 and "invalid choice" in bad.stderr


def test_a_multi_line_error_is_one_line_of_clauses():
    """fvf.quad_mesh's error has a line per attempt: on the command line each becomes a
    clause ("; " between them), a line ending in ":" or "." runs on with a space."""
    from fvf.cli.main import _one_line

    exc = fvf.QuadMeshError(
        "no valid quad mesh after 2 attempts:\n  input: 3 flipped\n  remeshed: 2   folded\n"
        "Where: (0, 0, 1).\nWhat to try: more quads."
    )
    assert _one_line(exc) == (
        "QuadMeshError: no valid quad mesh after 2 attempts: input: 3 flipped; "
        "remeshed: 2 folded; Where: (0, 0, 1). What to try: more quads."
    )


def test_the_advice_names_only_options_the_command_takes():
    """Library messages say method='upwind', growth_limit=np.inf and max_products; the
    command says --method upwind and --growth-limit inf where it takes them, and leaves
    the clause out where it does not (``fvf transport`` has no --method; no command has
    max_products)."""
    import argparse

    from fvf.cli.main import _cli_words

    text = (
        "grew 300x; use method='upwind' (bounded on every mesh); pass growth_limit=np.inf "
        "to accept it. Shorten t, flow fewer columns, use method='upwind' (a flow with a "
        "maximum principle), or raise max_products (and pass progress= to follow it)."
    )
    flow = _cli_words(text, argparse.Namespace(method="chapter", growth_limit=100.0))
    transport = _cli_words(text, argparse.Namespace(growth_limit=100.0))
    assert flow.count("--method upwind") == 2 and "--growth-limit inf" in flow
    assert "method" not in transport and "--growth-limit inf" in transport
    for said in (flow, transport):
        assert "max_products" not in said and "progress=" not in said and "np.inf" not in said
        assert ";;" not in said and ",." not in said
    assert transport.endswith("Shorten t, flow fewer columns.")


def test_a_ground_truth_full_of_one_value_is_pointed_out(tmp_path, capsys):
    """The shared camel truth files mark 17 % of their rows 0 for "no truth"; without
    --truth-missing those rows counted as errors and the mean error was 10x the
    documented one, silently. The command now says so, and names the option."""
    import argparse

    from fvf.cli.commands.match import _read_truth

    ball = fvf.icosphere(2)
    for name in ("a.obj", "b.obj"):
        fvf.write_mesh(tmp_path / name, ball.vertices, ball.faces)
    truth = np.arange(ball.n_vertices)
    truth[::4] = 0
    np.savetxt(tmp_path / "t.txt", truth, fmt="%d")
    args = argparse.Namespace(
        mesh_1=str(tmp_path / "a.obj"), mesh_2=str(tmp_path / "b.obj"),
        truth=str(tmp_path / "t.txt"), truth_missing=None,
    )  # fmt: skip
    _read_truth(args)
    assert "pass --truth-missing 0" in capsys.readouterr().err
    args.truth_missing = 0
    _read_truth(args)
    assert capsys.readouterr().err == ""
