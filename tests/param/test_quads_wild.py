"""fvf.quad_mesh and ``fvf quad`` on meshes people actually have (tests/param/wild_corpus.py),
judged by an independent checker (tests/param/quadcheck.py).

The promise (``test_promise``): for every corpus mesh, read from its file as a user would,
``fvf.quad_mesh`` returns a quad mesh that quadcheck accepts, or raises an
:class:`fvf.FvfError` -- never a foreign exception, never a mesh quadcheck rejects
without an error. The goal (``test_valid``): a valid quad mesh for every corpus mesh (open
surfaces and several parts included). Cases that fail today are ``xfail(strict=False)``
with the measured reason, so that the file passes now and an XPASS shows progress.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import fvf
import quadcheck as qc
import wild_corpus as wc

TARGET = 500  # quads, default suite
TARGET_SLOW = 2000

# Measured at TARGET quads: every corpus mesh keeps the promise (a valid mesh or a typed
# error). (Fold counts vary a little with the BLAS thread count; the suite runs on one
# thread, see conftest.py.)
PROMISE_XFAIL: dict[str, str] = {}
# No valid quad mesh today (the promise holds: a typed error).
VALID_XFAIL = {
    "cad_thin_tray": "QuadMeshError at 500 quads: walls 0.13 quad edges thick, the rib's "
    "quads fold (valid at 2,000)",
    "cad_flush_fins": "QuadMeshError at 500 quads: fins 0.3 quad edges thick flush with the "
    "plate's faces (coplanar comb faces; valid at 2,000)",
}
# Measured at TARGET_SLOW quads (slow suite).
PROMISE_XFAIL_SLOW: dict[str, str] = {}
VALID_XFAIL_SLOW: dict[str, str] = {}
CLI_XFAIL: dict[str, str] = {}


#: Corpus meshes kept to the slow suite: two thin-walled parts (19-24 s each to their
#: typed errors at the default target; the stretched rims are tested in
#: tests/param/test_strips.py) and the two scans with holes cut (8-9 s each; holes and
#: boundary loops are tested in the default suite by tests/param/test_quads_csg.py's
#: sphere with three holes). The U channel is valid from its second attempt (0.6 s).
SLOW = {  # 4-8 s each
    "cad_thin_tray",
    "cad_flush_fins",
    "cad_plate_holes",
    "cad_two_parts",
    "cad_sliver_cylinder",
    "scan_body_holes",
    "scan_potato_hole",
    "scan_multipart",
    "scan_torus",
}


def _cases(xfails: dict[str, str], slow: bool = False) -> list:
    out = []
    for name in wc.names():
        marks = [pytest.mark.slow] if slow or name in SLOW else []
        if name in xfails:
            marks.append(pytest.mark.xfail(strict=False, reason=xfails[name]))
        out.append(pytest.param(name, marks=marks, id=name))
    return out


_RUNS: dict = {}


def run(name: str, target: int, tmp_path_factory) -> dict:
    """Write ``name`` in its natural format, read it back, run fvf.quad_mesh once per
    (name, target) and judge the result."""
    if not wc.available(name):
        pytest.skip(f"{name} needs manifold3d")
    key = (name, target)
    if key not in _RUNS:
        folder = tmp_path_factory.mktemp("wild")
        V, F = wc.load(wc.write_corpus(folder, [name])[name])
        result: dict = {"V": V, "F": F}
        try:
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                Vq, Q = fvf.quad_mesh(fvf.TriMesh(V, F), target_faces=target)
            result.update(quads=(Vq, Q), verdict=qc.check(V, F, Vq, Q), warnings=caught)
        except fvf.FvfError as exc:
            result["typed"] = exc
        except Exception as exc:  # noqa: BLE001 -- what the promise forbids; reported below
            result["foreign"] = exc
        _RUNS[key] = result
    return _RUNS[key]


def _assert_promise(r: dict) -> None:
    if "foreign" in r:
        exc = r["foreign"]
        pytest.fail(f"foreign exception {type(exc).__name__}: {exc}")
    if "typed" in r:
        assert isinstance(r["typed"], fvf.FvfError)
        assert str(r["typed"]), "a typed error says what went wrong"
        return
    v = r["verdict"]
    assert v.valid, f"returned a mesh quadcheck rejects: {v.summary()}"


def _assert_valid(r: dict) -> None:
    _assert_promise(r)
    assert "typed" not in r, f"{type(r['typed']).__name__}: {r['typed']}"


@pytest.mark.parametrize("name", _cases(PROMISE_XFAIL))
def test_promise(name, tmp_path_factory):
    _assert_promise(run(name, TARGET, tmp_path_factory))


@pytest.mark.parametrize("name", _cases(VALID_XFAIL))
def test_valid(name, tmp_path_factory):
    r = run(name, TARGET, tmp_path_factory)
    _assert_valid(r)
    Vq, Q = r["quads"]
    assert 0.5 * TARGET <= Q.shape[0] <= 2.0 * TARGET


@pytest.mark.parametrize("name", _cases(PROMISE_XFAIL_SLOW, slow=True))
def test_promise_2000(name, tmp_path_factory):
    _assert_promise(run(name, TARGET_SLOW, tmp_path_factory))


@pytest.mark.parametrize("name", _cases(VALID_XFAIL_SLOW, slow=True))
def test_valid_2000(name, tmp_path_factory):
    _assert_valid(run(name, TARGET_SLOW, tmp_path_factory))


# ---------------------------------------------------------------------------- the command
def _cli(name: str, tmp_path, capsys) -> None:
    """``fvf quad FILE`` keeps the promise: exit 0 with a valid quad mesh written, or exit
    2 (bad input) / 4 (computation failed) with a one-line message and no traceback."""
    from fvf.cli.main import main
    from fvf.io.meshfile import read_quad_mesh

    if not wc.available(name):
        pytest.skip(f"{name} needs manifold3d")
    path = wc.write_corpus(tmp_path, [name])[name]
    out = tmp_path / f"{name}_quads.obj"
    rc = main(["quad", str(path), "--faces", str(TARGET), "-o", str(out)])
    err = capsys.readouterr().err
    assert "Traceback" not in err
    if rc == 0:
        Vq, Q = read_quad_mesh(out)
        V, F = wc.load(path)
        v = qc.check(V, F, Vq, np.asarray(Q))
        assert v.valid, v.summary()
    else:
        assert rc in (2, 4), (rc, err)
        assert err.strip() and not out.exists()


CLI_DEFAULT = ["cad_box_hole", "scan_torus", "tiny_two_triangles"]


@pytest.mark.parametrize(
    "name",
    [
        pytest.param(n, marks=[pytest.mark.xfail(strict=False, reason=CLI_XFAIL[n])])
        if n in CLI_XFAIL
        else n
        for n in CLI_DEFAULT
    ],
)
def test_cli(name, tmp_path, capsys):
    _cli(name, tmp_path, capsys)


@pytest.mark.parametrize("name", _cases(CLI_XFAIL, slow=True))
def test_cli_all(name, tmp_path, capsys):
    _cli(name, tmp_path, capsys)


# ---------------------------------------------------------------------------- the corpus
@pytest.mark.parametrize("name", wc.names())
def test_corpus_is_as_documented(name, tmp_path):
    """Each corpus mesh has the χ, parts and boundary loops of its table row, survives its
    file format, and has a size fit for tests."""
    if not wc.available(name):
        pytest.skip(f"{name} needs manifold3d")
    e = wc.ENTRIES[name]
    V, F = wc.mesh(name)
    assert V.dtype == np.float64 and F.dtype == np.int64 and V.shape[1] == F.shape[1] == 3
    t = qc.topology(V.shape[0], F)
    assert (t.chi, t.components, t.boundary_loops) == (e.chi, e.components, e.loops)
    assert t.edge_uses_max <= 2 and t.duplicated_directed == 0 and t.pinched_vertices == 0
    assert t.n_used == V.shape[0]
    if e.loops == 0:  # outward normals: positive enclosed volume
        T = V[F] - V.mean(axis=0)
        assert np.einsum("ij,ij->i", T[:, 0], np.cross(T[:, 1], T[:, 2])).sum() > 0
    if e.kind != "tiny":  # box-like CAD parts export as a few dozen triangles
        assert (600 if e.kind == "scan" else 12) <= F.shape[0] <= 20_000
    W, G = wc.load(wc.write_corpus(tmp_path, [name])[name])
    assert G.shape == F.shape and W.shape == V.shape
    tol = 1e-6 * float(np.abs(V).max()) if e.fmt == "stl" else 1e-9 * float(np.abs(V).max())
    assert np.abs(np.sort(W, axis=0) - np.sort(V, axis=0)).max() <= tol


def test_corpus_is_deterministic():
    for name in ("cad_sliver_cylinder", "scan_potato", "scan_torus", "tiny_strip"):
        V, F = wc.ENTRIES[name].build()
        W, G = wc.mesh(name)
        np.testing.assert_array_equal(V, W)
        np.testing.assert_array_equal(F, G)


def test_stl_soup_roundtrip(tmp_path):
    V, F = wc.tiny_cube12()
    wc.write_stl(tmp_path / "c.stl", V, F)
    raw = (tmp_path / "c.stl").read_bytes()
    assert len(raw) == 84 + 50 * 12  # a soup: 3 corners per facet, no shared vertices
    W, G = wc.read_stl(tmp_path / "c.stl")
    assert W.shape == (8, 3) and G.shape == (12, 3)
    np.testing.assert_allclose(np.sort(W[G].reshape(-1, 3), 0), np.sort(V[F].reshape(-1, 3), 0))


def test_quad_repairs_an_exporters_t_junction_and_says_so(tmp_path, capsys):
    """A zero-area face whose apex lies on the edge across (a CAD exporter's T-junction):
    `fvf quad` repairs it as `fvf repair` does, says so, and writes a quad mesh that the
    independent judge finds valid against the repaired surface."""
    from fvf.cli.main import main
    from fvf.io.meshfile import read_quad_mesh

    s = fvf.icosphere(3)
    V, F = s.vertices.copy(), s.faces.copy()
    a, b, c = F[0]
    V[c] = 0.25 * V[a] + 0.75 * V[b]
    src, out = tmp_path / "t_junction.obj", tmp_path / "q.obj"
    fvf.write_mesh(src, V, F)
    assert main(["quad", str(src), "--faces", "300", "-o", str(out)]) == 0
    err = capsys.readouterr().err
    assert "have zero area; repaired as `fvf repair` does (split_t_junctions" in err
    Vq, Q = read_quad_mesh(out)
    fixed = fvf.repair_mesh(V, F)
    assert qc.check(fixed.vertices, fixed.faces, Vq, np.asarray(Q)).valid


def test_a_ribbon_is_closed_by_its_mirror_image_and_keeps_its_four_corners():
    """A helical ribbon one triangle wide: domes over its boundary loop would hold 9.4
    times its area (every attempt on them failed), its mirror image holds its area. The
    ribbon's quads, found valid by quadcheck, have its one boundary loop, and its four
    corners (where the loop turns by 90°) are in one quad each."""
    V, F = wc.tiny_strip()
    with warnings.catch_warnings():
        warnings.simplefilter("error", fvf.FvfWarning)
        made = fvf.quad_mesh((V, F), target_faces=500)
    assert len(made.attempts) <= 2 and "valid" in made.attempts[-1]
    assert qc.check(V, F, made.vertices, made.quads).valid
    fans = np.bincount(made.quads.ravel())
    assert np.count_nonzero(fans == 1) == 4
    assert abs(made.quads.shape[0] - 500) < 0.25 * 500


@pytest.mark.slow
def test_a_part_without_thin_strips_gets_no_stretched_attempt(tmp_path):
    """The two parts' iso-line attempts on the exporter's triangles fail; the stretched
    attempt after each would be the same attempt (no strip narrower than a quad: the
    same 16 and 100 flipped triangles), so it is skipped and the remeshed surface is
    tried next."""
    if not wc.available("cad_two_parts"):
        pytest.skip("cad_two_parts needs manifold3d")
    V, F = wc.load(wc.write_corpus(tmp_path, ["cad_two_parts"])["cad_two_parts"])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        r = fvf.quad_mesh(fvf.TriMesh(V, F), target_faces=2000)
    assert qc.check(V, F, r.vertices, r.quads).valid
    assert len(r.attempts) == 4, r.attempts
    assert not any("thin strips" in a for a in r.attempts), r.attempts
