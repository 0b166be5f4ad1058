"""fvf.chapter: one name per chapter symbol (docs/chapter.md), each an alias of the real
function."""

import inspect

import numpy as np

import fvf
from fvf import chapter as ch

NAMES = {
    "A_F": fvf.face_areas, "A_V": fvf.vertex_areas, "grad": fvf.grad, "div": fvf.div,
    "J": fvf.rotation, "I_VF": fvf.face_to_vertex, "I_FV": fvf.vertex_to_face,
    "L": fvf.laplacian, "D_F": fvf.D_F, "D_V": fvf.D_V, "Dbar_F": fvf.Dbar_F,
    "Dbar_V": fvf.Dbar_V, "Dtilde_F": fvf.Dtilde_F, "Dtilde_V": fvf.Dtilde_V,
    "Dtilde_dual_F": fvf.Dtilde_dual_F, "Dtilde_dual_V": fvf.Dtilde_dual_V,
    "bracket_V": fvf.bracket_V, "bracket_F": fvf.bracket_F, "B": fvf.B, "ad": fvf.ad,
    "poisson_bracket": fvf.poisson_bracket, "flow": fvf.flow, "extract_field": fvf.extract_field,
    "laplace_basis": fvf.laplace_basis, "killing_fields": fvf.killing_fields,
    "singularities": fvf.singularities, "functional_map": fvf.functional_map,
    "Ad": fvf.Ad, "interpolate": fvf.interpolate, "rescale": fvf.rescale,
    "acap_fields": fvf.acap_fields,
}  # fmt: skip


def test_names_are_aliases():
    assert set(ch.__all__) == set(NAMES)
    for name, fn in NAMES.items():
        assert getattr(ch, name) is fn, name
        first = next(iter(inspect.signature(fn).parameters))
        assert first == ("mesh_1" if name == "functional_map" else "mesh"), name


def test_shapes_on_a_small_mesh():
    mesh = fvf.icosphere(1)
    n, m = mesh.n_vertices, mesh.n_faces
    X = mesh.vertices
    v = fvf.rotate(mesh, fvf.gradient(mesh, X[:, 2]))
    w = fvf.gradient(mesh, X[:, 0])
    f = X[:, 1]
    assert ch.A_F(mesh).shape == (m,) and ch.A_V(mesh).shape == (n,)
    expected = {
        "grad": (3 * m, n), "div": (n, 3 * m), "J": (3 * m, 3 * m), "I_VF": (n, m),
        "I_FV": (m, n), "L": (n, n),
    }  # fmt: skip
    for name, shape in expected.items():
        assert getattr(ch, name)(mesh).shape == shape
    assert ch.D_F(mesh, v).shape == (m, n) and ch.D_V(mesh, v).shape == (n, n)
    assert ch.Dbar_F(mesh, f).shape == (m, 3 * m) and ch.Dbar_V(mesh, f).shape == (n, 3 * m)
    assert ch.Dtilde_F(mesh, v).shape == (n, m) and ch.Dtilde_V(mesh, v).shape == (n, n)
    assert ch.Dtilde_dual_F(mesh, np.ones(m)).shape == (n, 3 * m)
    assert ch.Dtilde_dual_V(mesh, f).shape == (n, 3 * m)
    for name in ("bracket_V", "bracket_F"):
        assert getattr(ch, name)(mesh, v, w).shape == (n, n)
    assert ch.B(mesh, v, w).shape == (3 * m, 3 * m)
    assert ch.ad(mesh, v).shape == (3 * n, 3 * m)
    assert ch.poisson_bracket(mesh, f, X[:, 0]).shape == (m,)
    assert ch.flow(mesh, v, f, 0.1).shape == (n,)
    assert ch.flow(mesh, v, f, [0.1, 0.2, 0.3]).shape == (3, n)
    assert ch.extract_field(mesh, ch.D_F(mesh, v)).shape == (m, 3)
    assert ch.extract_field(mesh, ch.D_V(mesh, v)).shape == (n, 3)
