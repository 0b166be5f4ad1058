"""The hostile inputs still open: files that are not what they seem, options that would
hang or crash, fields at the ends of float64, empty time arrays. Each either works (with
the right answer) or raises the documented typed error quickly.

The inputs are the corpus entries of tests/corpus.py (:func:`hostile_files`,
:func:`hostile_data_files`, :func:`hostile_options`, :func:`extreme_fields`).
"""

from __future__ import annotations

import signal
import warnings

import numpy as np
import pytest

import fvf
from corpus import (
    extreme_fields,
    hostile_data_files,
    hostile_files,
    hostile_options,
    make_file,
)
from fvf import errors
from fvf.cli.main import EXIT_BAD_INPUT, EXIT_OK, main


@pytest.fixture
def alarm():
    """Fail (instead of hanging forever) when a call takes more than 20 s."""

    def hang(signum, frame):
        raise TimeoutError("hung: more than 20 s")

    previous = signal.signal(signal.SIGALRM, hang)
    signal.alarm(20)
    yield
    signal.alarm(0)
    signal.signal(signal.SIGALRM, previous)


# ---------------------------------------------------------------------------- mesh files
FILES = hostile_files()


@pytest.mark.parametrize("name", sorted(FILES))
def test_hostile_mesh_files(name, tmp_path, alarm):
    entry = FILES[name]
    path = make_file(tmp_path / name, entry)
    if entry.error is not None:
        with pytest.raises(entry.error) as info:
            fvf.read_mesh(path)
        for word in (str(path), *entry.words):
            assert word in str(info.value), (word, str(info.value))
        return
    V, F = fvf.read_mesh(path)
    assert np.array_equal(V, entry.vertices), V
    assert np.array_equal(F, [[0, 1, 2]] if entry.faces is None else entry.faces)
    if path.suffix == ".ply":
        assert fvf.io.read_ply_properties(path) == ({}, {})


def test_obj_bom_keeps_the_first_vertex(tmp_path):
    """Without handling, the BOM glues onto 'v' and the first vertex line is skipped."""
    path = tmp_path / "bom.obj"
    path.write_bytes(b"\xef\xbb\xbfv 5 5 5\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 2 3 4\n")
    V, F = fvf.read_mesh(path)
    assert V.shape == (4, 3) and V[0].tolist() == [5, 5, 5] and F.tolist() == [[1, 2, 3]]


def test_4off_divides_by_w_and_large_files_stay_fast(tmp_path):
    mesh = fvf.icosphere(3)
    w = np.linspace(0.5, 2.0, mesh.n_vertices)
    rows = np.column_stack([mesh.vertices * w[:, None], w])
    text = f"4OFF\n{mesh.n_vertices} {mesh.n_faces} 0\n"
    text += "".join(" ".join(f"{x:.17g}" for x in r) + "\n" for r in rows)
    text += "".join(f"3 {a} {b} {c}\n" for a, b, c in mesh.faces)
    path = tmp_path / "h.off"
    path.write_text(text)
    V, F = fvf.read_mesh(path)
    assert np.allclose(V, mesh.vertices, rtol=1e-15, atol=1e-15)
    assert np.array_equal(F, mesh.faces)


@pytest.mark.perf
def test_strict_numbers_cost_nothing_on_clean_files(tmp_path):
    """The check of number syntax takes one pass over the characters: a 20k-face OBJ
    reads as fast as before (the check is below 15 % of the read)."""
    import time

    from fvf.io import meshfile

    mesh = fvf.icosphere(5)
    path = tmp_path / "big.obj"
    fvf.write_mesh(path, mesh.vertices, mesh.faces)
    t0 = time.perf_counter()
    fvf.read_mesh(path)
    full = time.perf_counter() - t0
    lines = path.read_text().splitlines()
    tokens = [t for line in lines if line.startswith("v ") for t in line.split()[1:]]
    t0 = time.perf_counter()
    meshfile._strict(path, tokens, np.array([len(tokens)]), [1], np.float64, "x")
    check = time.perf_counter() - t0
    assert check < 0.15 * full + 0.005, (check, full)


# ---------------------------------------------------------------------------- data files
@pytest.fixture(scope="module")
def work(tmp_path_factory):
    d = tmp_path_factory.mktemp("hostile")
    mesh = fvf.icosphere(2)
    fvf.write_mesh(d / "ico.obj", mesh.vertices, mesh.faces)
    return d, mesh


DATA = sorted(hostile_data_files(fvf.icosphere(2)))


@pytest.mark.parametrize("name", DATA)
def test_hostile_data_files(name, work, alarm, capsys):
    """read_data reads the keys a command uses, nothing else; every failure is typed and
    the command says it in one line with status 2."""
    d, mesh = work
    write, expected = hostile_data_files(mesh)[name]
    path = d / f"{name}.npz"
    if not path.exists() and not path.is_symlink():
        write(path)
    argv = ["flow", str(d / "ico.obj"), str(path), "--t", "0.1", "-o", str(d / f"out_{name}")]
    status = main(argv)
    err = capsys.readouterr().err
    if expected == "ok":
        assert status == EXIT_OK, err
        return
    assert status == EXIT_BAD_INPUT and err.count("\n") == 1, err
    assert expected.__name__ in err
    with pytest.raises(expected):
        data = fvf.io.read_data(path, mesh)
        data.field("v", mesh)
        data.functions("f", mesh)


def test_a_huge_used_key_is_not_allocated(work):
    d, mesh = work
    write, _ = hostile_data_files(mesh)["used_key_declares_8tb"]
    path = d / "huge_v.npz"
    write(path)
    data = fvf.io.read_data(path, mesh)
    with pytest.raises(errors.DataFileError, match=r"'v' declares .*\(1000000000000,\)"):
        data["v"]


# ---------------------------------------------------------------------------- options
OPTIONS = sorted(hostile_options(fvf.icosphere(2)))


@pytest.mark.parametrize("name", OPTIONS)
def test_hostile_options(name, alarm):
    call, error = hostile_options(fvf.icosphere(2))[name]
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a refused option warns about nothing first
        with pytest.raises(error):
            call()


def _render_options():
    return {
        "size_100000": {"size": (100000, 100000)},
        "size_float": {"size": (640.5, 480)},
        "clim_nan": {"function": "f", "clim": (np.nan, np.nan)},
        "clim_reversed": {"function": "f", "clim": (1.0, 0.0)},
        "max_arrows_-5": {"field": "v", "max_arrows": -5},
        "max_arrows_0": {"field": "v", "max_arrows": 0},
        "arrow_scale_inf": {"field": "v", "arrow_scale": np.inf},
        "arrow_scale_nan": {"field": "v", "arrow_scale": np.nan},
        "view_nan": {"view": (np.nan, 10.0)},
        "zoom_inf": {"view": {"zoom": np.inf}},
        "backend_unknown": {"backend": "opengl"},
    }


@pytest.mark.parametrize("name", sorted(_render_options()))
def test_render_options_are_checked_before_any_work(name, tmp_path, alarm):
    viz = pytest.importorskip("fvf.viz")
    pytest.importorskip("matplotlib")
    mesh = fvf.icosphere(1)
    kwargs = dict(_render_options()[name])
    if kwargs.get("function") == "f":
        kwargs["function"] = mesh.vertices[:, 0]
    if kwargs.get("field") == "v":
        kwargs["field"] = mesh.project_tangent(np.cross([0, 0, 1.0], mesh.face_centroids))
    with pytest.raises(errors.ParameterError):
        viz.render(mesh, tmp_path / "x.png", **kwargs)
    assert not (tmp_path / "x.png").exists()


CLI_OPTIONS = [
    (["flow", "--t", "1_0"], "--t"),
    (["flow", "--t", "1", "--method", "cayley", "--dt", "nan"], "--dt"),
    (["flow", "--t", "1", "--method", "cayley", "--dt", "-1"], "dt"),
    (["flow", "--t", "1", "--method", "spectral", "--k", "1_0"], "--k"),
    (["flow", "--t", "1", "--method", "spectral", "--k", "0"], "k must"),
    (["flow", "--t", "1", "--growth-limit", "nan"], "--growth-limit"),
    (["flow", "--t", "1", "--growth-limit", "-3"], "growth_limit"),
    (["render", "--size", "100000", "100000"], "size"),
    (["render", "--clim", "nan", "nan"], "--clim"),
    (["render", "--max-arrows", "-5"], "max_arrows"),
    (["render", "--view", "inf", "10"], "--view"),
    (["render", "--arrow-scale", "0"], "arrow_scale"),
]


def test_cli_options_are_refused_in_one_line(work, capsys, alarm):
    d, mesh = work
    v = mesh.project_tangent(np.cross([0, 0, 1.0], mesh.face_centroids))
    np.savez(d / "fields.npz", f=mesh.vertices[:, 0], v=v)
    viz = True
    try:
        import matplotlib  # noqa: F401
    except ImportError:
        viz = False
    for args, words in CLI_OPTIONS:
        if args[0] == "render" and not viz:
            continue
        argv = [args[0], str(d / "ico.obj"), str(d / "fields.npz"), *args[1:]]
        out = ["-o", str(d / "o.png")] if args[0] == "render" else ["-o", str(d / "o")]
        argv += ["--field", "v", *out] if args[0] == "render" else out
        status = main(argv)
        err = capsys.readouterr().err
        assert status == EXIT_BAD_INPUT and err.count("\n") == 1 and words in err, (args, err)
        assert not (d / "o.npz").exists() and not (d / "o.png").exists()


# ---------------------------------------------------------------------------- sizes
def test_indices_do_not_depend_on_the_field_size(rng):
    mesh = fvf.jittered_sphere(2, 0.3, seed=1)
    fields = extreme_fields(mesh, rng)
    ids, ind = fvf.singularities(mesh, fields["unit"])
    assert ind.sum() == 2 and ids.size > 2
    for name in ("tiny", "huge"):
        got = fvf.singularities(mesh, fields[name])
        assert np.array_equal(got[0], ids) and np.array_equal(got[1], ind), name
    U = np.asarray(fvf.face_to_vertex(mesh) @ fields["unit"])
    ref = fvf.face_indices(mesh, U, zero="warn")
    for scale in (1e-200, 1e200):
        assert np.array_equal(fvf.face_indices(mesh, scale * U, zero="warn"), ref)


def test_bracket_norm_is_scale_free(rng):
    mesh = fvf.jittered_sphere(2, 0.3, seed=1)
    u = extreme_fields(mesh, rng)
    w = extreme_fields(mesh, np.random.default_rng(5))
    ref = fvf.bracket_norm(mesh, u["unit"], w["unit"])
    for a, b, s in (("huge", "unit", 1e200), ("tiny", "unit", 1e-200), ("huge", "tiny", 1.0)):
        got = fvf.bracket_norm(mesh, u[a], w[b])
        assert np.allclose(got, s * ref, rtol=1e-12, atol=0), (a, b)
        face = fvf.bracket_norm(mesh, u[a], w[b], where="face")
        assert np.allclose(face, s * fvf.bracket_norm(mesh, u["unit"], w["unit"], "face"))
    assert np.allclose(fvf.commutator_field(mesh, u["huge"], w["unit"]) / 1e200,
                       fvf.commutator_field(mesh, u["unit"], w["unit"]), rtol=1e-12)  # fmt: skip
    with pytest.raises(errors.FieldValueError, match="beyond float64.*bilinear"):
        fvf.bracket_norm(mesh, u["huge"], w["huge"])  # 1e400: out of reach, said so


def test_huge_non_tangent_fields_are_still_projected(rng):
    mesh = fvf.icosphere(2)
    u = extreme_fields(mesh, rng)["huge"] + 1e199 * mesh.face_normals
    with pytest.warns(errors.NonTangentFieldWarning):
        out = fvf.as_face_field(mesh, u)
    assert np.isfinite(out).all()
    assert np.abs(np.einsum("ij,ij->i", out, mesh.face_normals)).max() < 1e-8 * 1e200


def test_float32_tangent_fields_do_not_warn(rng):
    mesh = fvf.jittered_sphere(3, 0.3, seed=2)
    u = mesh.project_tangent(rng.standard_normal((mesh.n_faces, 3))).astype(np.float32)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        fvf.as_face_field(mesh, u)
        fvf.flow(mesh, u, mesh.vertices[:, 0], 0.01, method="upwind")
    bent = (u + 1e-3 * mesh.face_normals).astype(np.float32)  # a real normal part still warns
    with pytest.warns(errors.NonTangentFieldWarning):
        fvf.as_face_field(mesh, bent)
    assert fvf.mesh.inputs.tangent_rtol(np.float32) == pytest.approx(64 * 2.0**-23)
    assert fvf.mesh.inputs.tangent_rtol(np.float64) == 1e-8


@pytest.mark.parametrize("scale", [1e160, 1e-170, 1e80])
def test_mesh_scale_out_of_reach_says_so(scale):
    ico = fvf.icosphere(1)
    with pytest.raises(errors.MeshScaleError, match="rescale") as info:
        fvf.TriMesh(scale * ico.vertices, ico.faces)
    assert "zero area" not in str(info.value)
    for ok in (1e70, 1e-70):
        mesh = fvf.TriMesh(ok * ico.vertices, ico.faces)
        assert np.isfinite(mesh.face_areas).all() and (mesh.face_areas > 0).all()


def test_cayley_with_a_huge_field_names_the_real_problem():
    mesh = fvf.icosphere(2)
    v = 1e200 * mesh.project_tangent(np.cross([0, 0, 1.0], mesh.face_centroids))
    with pytest.raises(errors.FlowOverflowError, match="steps") as info:
        fvf.flow(mesh, v, mesh.vertices[:, 0], 1.0, method="cayley")
    assert "dt must be positive" not in str(info.value)


def test_spectral_overflow_is_a_flow_overflow_error():
    mesh = fvf.icosphere(2)
    v = 1e150 * fvf.gradient(mesh, mesh.vertices[:, 2])
    with pytest.raises(errors.FlowOverflowError, match="spectral flow overflowed"):
        fvf.flow(mesh, v, mesh.vertices[:, 0], 1e150, method="spectral", k=10)


# ---------------------------------------------------------------------------- empty times
@pytest.mark.parametrize("method", ["chapter", "upwind", "skew", "cayley", "spectral"])
def test_empty_times_give_empty_results(method):
    """Documented: an empty array of times gives (0,) + f.shape, for every method."""
    mesh = fvf.icosphere(2)
    v = mesh.project_tangent(np.cross([0, 0, 1.0], mesh.face_centroids))
    f = mesh.vertices[:, :2]
    options = {"k": 10} if method == "spectral" else {}
    out = fvf.flow(mesh, v, f, np.array([]), method=method, **options)
    assert out.shape == (0, mesh.n_vertices, 2) and out.dtype == np.float64
    assert fvf.flow(mesh, v, f[:, 0], [], method=method, **options).shape == (0, 162)


def test_empty_times_elsewhere():
    mesh = fvf.icosphere(2)
    v = mesh.project_tangent(np.cross([0, 0, 1.0], mesh.face_centroids))
    assert fvf.FunctionalFlow(mesh, v)(mesh.vertices[:, 0], []).shape == (0, 162)
    result = fvf.FieldTransport(mesh, v)(v, [])
    assert result.fields.shape == (0, 320, 3) and result.normal_part.shape == (0,)
    assert fvf.Ad(mesh, v, v, []).shape == (0, 320, 3)
    assert fvf.interpolate(mesh, v, v, -v, []).shape == (0, 320, 3)
    basis = fvf.SpectralBasis(mesh, 8)
    assert basis.reduced_flow(v, mesh.vertices[:, 0], []).shape == (0, 162)
