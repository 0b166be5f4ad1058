"""One entrance, audited: every public parameter that takes a mesh goes through
:func:`fvf.as_mesh`, one repair policy serves every form a mesh comes in
(``as_mesh(..., repair=True)`` is what :func:`fvf.match` does), and foreign objects are
converted once while their arrays are unchanged (PyVista's too, which are not hashable)."""

from __future__ import annotations

import gc
import importlib
import inspect

import numpy as np
import pytest

import fvf
from fvf.mesh import convert

#: Public namespaces whose callables are audited.
SPACES = ("fvf", "fvf.viz", "fvf.design", "fvf.mesh", "fvf.param", "fvf.spectral", "fvf.io")
#: Results and records that hold a mesh (built by fvf), not entrances.
HOLDERS = {"FluidResult", "LicTexture", "PreparedMesh", "as_mesh"}


def _is_mesh_parameter(name: str) -> bool:
    return name == "mesh" or (name.startswith("mesh_") and name[5:].isdigit())


def _mesh_parameters() -> list[tuple[str, object, str]]:
    """(qualified name, callable, parameter) for every public mesh parameter."""
    out, seen = [], set()
    for space_name in SPACES:
        space = importlib.import_module(space_name)
        for name in space.__all__:
            obj = getattr(space, name)
            if name in HOLDERS or not callable(obj) or inspect.ismodule(obj) or id(obj) in seen:
                continue
            seen.add(id(obj))
            target = obj.__init__ if inspect.isclass(obj) else obj
            try:
                params = inspect.signature(target).parameters
            except (TypeError, ValueError):
                continue
            for p in params:
                if _is_mesh_parameter(p):
                    out.append((f"{space_name}.{name}", obj, p))
    return out


MESH_PARAMETERS = _mesh_parameters()


def _call_with(fn, parameter: str, value, other_mesh):
    """Call ``fn`` with ``value`` as ``parameter``, valid meshes as its other mesh
    parameters and None for every other required parameter."""
    target = fn.__init__ if inspect.isclass(fn) else fn
    params = list(inspect.signature(target).parameters.values())
    params = params[1:] if inspect.isclass(fn) else params
    args, kwargs = [], {}
    for p in params:
        if p.name == parameter:
            v = value
        elif _is_mesh_parameter(p.name):
            v = other_mesh
        elif p.default is inspect.Parameter.empty and p.kind not in (
            p.VAR_POSITIONAL,
            p.VAR_KEYWORD,
        ):
            v = None
        else:
            continue
        if p.kind == p.KEYWORD_ONLY:
            kwargs[p.name] = v
        else:
            args.append(v)
    return fn(*args, **kwargs)


def test_the_audit_finds_the_entrances():
    names = {(n, p) for n, _, p in MESH_PARAMETERS}
    for expected in [
        ("fvf.design_field", "mesh"),
        ("fvf.functional_map", "mesh_2"),
        ("fvf.geodesic_errors", "mesh_1"),
        ("fvf.viz.render_correspondence", "mesh_2"),
        ("fvf.io.read_data", "mesh"),
        ("fvf.io.write_data", "mesh"),
        ("fvf.spectral.geodesic_distances", "mesh"),
    ]:
        assert expected in names
    assert len(names) > 80


@pytest.mark.parametrize(
    "name,fn,parameter", MESH_PARAMETERS, ids=[f"{n}:{p}" for n, _, p in MESH_PARAMETERS]
)
def test_every_mesh_parameter_goes_through_as_mesh(name, fn, parameter):
    """A foreign object in any mesh parameter gets as_mesh's TypeError, before any other
    argument (here None) is looked at: the parameter takes every fvf.MeshLike."""
    with pytest.raises(TypeError, match=r"as_mesh: got builtins\.object"):
        _call_with(fn, parameter, object(), fvf.icosphere(1))


@pytest.fixture(scope="module")
def forms(tmp_path_factory):
    """One mesh in every form: TriMesh, tuple, path, trimesh, PyVista, meshio."""
    mesh = fvf.jittered_sphere(2, 0.3, seed=4)
    V, F = mesh.vertices, mesh.faces
    path = tmp_path_factory.mktemp("forms") / "sphere.ply"
    fvf.write_mesh(path, V, F)
    out = {"TriMesh": mesh, "tuple": (V, F), "path": path}
    try:
        import trimesh

        out["trimesh"] = trimesh.Trimesh(V, F, process=False)
    except ImportError:
        pass
    try:
        import pyvista

        out["pyvista"] = pyvista.PolyData(V, np.column_stack([np.full(len(F), 3), F]).ravel())
    except ImportError:
        pass
    try:
        import meshio

        out["meshio"] = meshio.Mesh(V, [("triangle", F)])
    except ImportError:
        pass
    return out


def test_entrances_beyond_the_first_parameter_take_every_form(forms):
    mesh = forms["TriMesh"]
    p2p = np.arange(mesh.n_vertices)
    C = fvf.functional_map(mesh, mesh, p2p, 6)
    d = fvf.spectral.geodesic_distances(mesh, [0, 5])
    for kind, m in forms.items():
        assert np.allclose(fvf.functional_map(m, m, p2p, 6), C), kind
        assert np.allclose(fvf.functional_map(mesh, m, p2p, 6), C), kind
        assert fvf.mean_geodesic_error(m, p2p, p2p) == 0.0, kind
        assert np.allclose(fvf.spectral.geodesic_distances(m, [0, 5]), d), kind
        assert fvf.spectral.orientation_agreement(m, m, p2p) == pytest.approx(1.0), kind
        assert np.allclose(fvf.mesh.vertex_normals(m), fvf.mesh.vertex_normals(mesh)), kind


def test_data_files_take_every_form(forms, tmp_path):
    mesh = forms["TriMesh"]
    f = mesh.vertices[:, 0]
    for kind, m in forms.items():
        out = fvf.io.write_data(
            tmp_path / f"{kind}.npz", {"f": f}, mesh=m, mesh_path=forms["path"], command="t"
        )
        assert np.array_equal(fvf.io.read_data(out, m)["f"], f), kind


# ---------------------------------------------------------------------------- repair
def _with_fin(mesh: fvf.TriMesh) -> tuple[np.ndarray, np.ndarray]:
    """The mesh plus one triangle glued on the edge of face 0: a non-manifold edge."""
    V, F = mesh.vertices, mesh.faces
    a, b = F[0, 0], F[0, 1]
    tip = 0.5 * (V[a] + V[b]) * 1.3
    return np.vstack([V, tip]), np.vstack([F, [[a, b, len(V)]]])


@pytest.fixture(scope="module")
def fins():
    """Two non-manifold shapes (the second a vertex permutation of the first)."""
    V, F = _with_fin(fvf.jittered_sphere(3, 0.3, seed=2))
    perm = np.random.default_rng(0).permutation(len(V))
    return (V, F), (V[perm], np.argsort(perm)[F]), perm


def test_repair_is_an_option_of_the_entrance(fins, tmp_path):
    (V, F), _, _ = fins
    with pytest.raises(fvf.NonManifoldError):
        fvf.as_mesh((V, F))
    repaired = fvf.as_mesh((V, F), repair=True)
    expected = fvf.mesh.prepare_mesh(V, F).mesh
    assert np.array_equal(repaired.vertices, expected.vertices)
    assert np.array_equal(repaired.faces, expected.faces)
    path = tmp_path / "fin.ply"
    fvf.write_mesh(path, V, F)
    forms = [path, str(path), [V, F], _Attrs(V, F)]
    trimesh = pytest.importorskip("trimesh")
    forms.append(trimesh.Trimesh(V, F, process=False))
    for form in forms:
        with pytest.raises(fvf.NonManifoldError):
            fvf.as_mesh(form)
        again = fvf.as_mesh(form, repair=True)
        assert np.array_equal(again.vertices, expected.vertices), type(form)
        assert np.array_equal(again.faces, expected.faces), type(form)
    ico = fvf.icosphere(1)
    assert fvf.as_mesh(ico, repair=True) is ico  # valid meshes are untouched
    valid = trimesh.Trimesh(ico.vertices, ico.faces, process=False)
    assert fvf.as_mesh(valid, repair=True) is fvf.as_mesh(valid)
    with pytest.raises(fvf.MeshIndexError):  # indices are never guessed
        fvf.as_mesh((ico.vertices, ico.faces + 1), repair=True)


def test_match_treats_every_form_alike(fins):
    """The reported failure: match(trimesh_a, trimesh_b) on non-manifold shapes raised
    NonManifoldError while match((Va, Fa), (Vb, Fb)) repaired and succeeded."""
    trimesh = pytest.importorskip("trimesh")
    (Va, Fa), (Vb, Fb), perm = fins
    expected = fvf.match((Va, Fa), (Vb, Fb), k=20, zoomout_samples=None)
    ta = trimesh.Trimesh(Va, Fa, process=False)
    tb = trimesh.Trimesh(Vb, Fb, process=False)
    p2p = fvf.match(ta, tb, k=20, zoomout_samples=None)
    assert np.array_equal(p2p, expected)
    assert np.mean(p2p == perm) > 0.9


class _Attrs:
    """A foreign mesh object that is not hashable (it defines ``==``), as PyVista's."""

    def __init__(self, V, F):
        self.vertices, self.faces = V, F

    def __eq__(self, other):
        return NotImplemented

    __hash__ = None  # type: ignore[assignment]


# ---------------------------------------------------------------------------- memo
def test_unhashable_objects_are_remembered():
    ico = fvf.icosphere(2)
    obj = _Attrs(ico.vertices.copy(), ico.faces.copy())
    mesh = fvf.as_mesh(obj)
    assert fvf.as_mesh(obj) is mesh
    obj.vertices[0] *= 1.01  # edited in place: a new TriMesh
    assert fvf.as_mesh(obj) is not mesh
    assert np.array_equal(fvf.as_mesh(obj).vertices, obj.vertices)
    key = id(obj)
    assert key in convert._MEMO
    del obj
    gc.collect()
    assert key not in convert._MEMO  # forgotten with the object


def test_pyvista_polydata_is_converted_once():
    pv = pytest.importorskip("pyvista")
    sphere = fvf.icosphere(5)
    V, F = sphere.vertices, sphere.faces
    pd = pv.PolyData(V, np.column_stack([np.full(len(F), 3), F]).ravel())
    mesh = fvf.as_mesh(pd)
    assert fvf.as_mesh(pd) is mesh and np.array_equal(mesh.faces, F)
    f = V[:, 2]
    g = fvf.gradient(pd, f)
    assert np.array_equal(g, fvf.gradient(sphere, f))
    pd.points[0] = pd.points[0] * 1.01  # edited: a new TriMesh
    assert fvf.as_mesh(pd) is not mesh
    np.asarray(pd.points)[1] *= 1.01  # edited through a plain numpy view: seen too
    edited = fvf.as_mesh(pd)
    assert np.array_equal(edited.vertices, np.asarray(pd.points))
