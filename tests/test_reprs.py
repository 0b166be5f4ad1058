"""Results print short: arrays by dtype and shape, never their values; a TriMesh shows a
table in a notebook."""

from __future__ import annotations

import dataclasses
import importlib
import pkgutil

import numpy as np
import pytest

import fvf
from fvf.numerics.summary import short_repr, short_value

#: Packages whose dataclasses are results of the library (viz, batch and cli hold records
#: of their own, shown by those layers).
LIBRARY = ("mesh", "numerics", "operators", "flows", "spectral", "design", "param")


def _result_dataclasses() -> list[type]:
    """Dataclasses of the library with a field annotated as an array."""
    found = []
    for package in LIBRARY:
        pkg = importlib.import_module(f"fvf.{package}")
        for info in pkgutil.iter_modules(pkg.__path__):
            module = importlib.import_module(f"fvf.{package}.{info.name}")
            for obj in vars(module).values():
                if (
                    isinstance(obj, type)
                    and obj.__module__ == module.__name__
                    and dataclasses.is_dataclass(obj)
                    and not obj.__name__.startswith("_")
                    and any("ndarray" in str(f.type) for f in dataclasses.fields(obj))
                ):
                    found.append(obj)
    return found


def _filled(cls: type):
    """An instance of ``cls`` with every array field 10000 x 3 and other fields None."""
    obj = object.__new__(cls)
    for f in dataclasses.fields(cls):
        value = np.arange(30_000.0).reshape(-1, 3) if "ndarray" in str(f.type) else None
        object.__setattr__(obj, f.name, value)
    return obj


RESULTS = _result_dataclasses()


def test_the_results_are_found():
    names = {cls.__name__ for cls in RESULTS}
    assert {"MatchResult", "FluidResult", "TransportResult", "SeamlessParameterization"} <= names


@pytest.mark.parametrize(
    "cls", [c for c in RESULTS if c is not fvf.RepairResult], ids=lambda c: c.__name__
)
def test_result_repr_is_short(cls):
    text = repr(_filled(cls))
    assert len(text) < 600 and "29999" not in text and "float64(10000, 3)" in text, text
    assert text.startswith(cls.__name__ + "(")


def test_short_value():
    import scipy.sparse as sp

    assert short_value(np.zeros((5, 3))) == "float64(5, 3)"
    assert short_value(sp.eye(4, format="csr")) == "csr(4, 4) nnz=4"
    assert short_value(0.1234567891) == "0.123457"
    assert short_value({"a": 1}) == "dict(1 key)"
    assert short_value(fvf.icosphere(1)) == "TriMesh(n_vertices=42, n_faces=80)"
    assert short_value(list(range(100))) == "list(100)"
    assert short_value(object()) == "object(...)"


def test_real_results_print_short():
    mesh = fvf.icosphere(3)
    v = mesh.project_tangent(np.cross([0, 0, 1.0], mesh.face_centroids))
    transport = fvf.FieldTransport(mesh, v)(v, [0.0, 0.1])
    assert repr(transport) == "TransportResult(fields=float64(2, 1280, 3), normal_part=float64(2,))"
    fluid = fvf.ideal_fluid(mesh, mesh.vertices[:, 2], 0.01, 2)
    assert "vorticity=float64(3, 642)" in repr(fluid) and "method='midpoint'" in repr(fluid)
    match = fvf.match_result(mesh, mesh, k=8, k_fit=4, zoomout_samples=None)
    text = repr(match)
    assert "C_12=float64(8, 8)" in text and "basis_1=SpectralBasis(...)" in text, text
    assert " object at 0x" not in text and len(text) < 500
    assert repr(match) == short_repr(match)
    repaired = repr(fvf.repair_mesh(mesh.vertices, mesh.faces))  # its own short repr
    assert repaired.startswith("RepairResult(642 -> 642 vertices") and len(repaired) < 200


def test_seamless_parameterization_repr():
    sp = fvf.seamless_parameterization(fvf.icosphere(2), target_faces=100)
    text = repr(sp)
    assert text.startswith("SeamlessParameterization(uv=float64(320, 3, 2)")
    assert "residual=" in text and len(text) < 500, text


@pytest.mark.parametrize(
    ("mesh", "row"),
    [
        (fvf.icosphere(1), "<th style='text-align:left'>genus</th><td style='text-align:right'>0"),
        (fvf.torus(12, 8), "<th style='text-align:left'>genus</th><td style='text-align:right'>1"),
        (fvf.disk(3), "boundary loops</th><td style='text-align:right'>1"),
    ],
)
def test_trimesh_html(mesh, row):
    html = mesh._repr_html_()
    assert html.startswith("<table>") and row in html
    for label in ("vertices", "faces", "components", "boundary loops", "χ", "genus"):
        assert label in html
    assert f"<td style='text-align:right'>{mesh.n_faces}</td>" in html


def test_trimesh_html_of_several_components():
    a = fvf.icosphere(1)
    V = np.vstack([a.vertices, a.vertices + 3.0])
    F = np.vstack([a.faces, a.faces + a.n_vertices])
    html = fvf.TriMesh(V, F)._repr_html_()
    assert "per component" in html and "<td style='text-align:right'>2</td>" in html
