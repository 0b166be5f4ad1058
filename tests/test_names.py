"""The naming rule of docs/conventions.md ("Names"), read from the page: an operator's
matrix is named for the operator and returns a sparse array; its application has another
name and returns ``matrix @ x`` as a plain array of the documented shape; every public
function returning a sparse array is named in that section."""

from __future__ import annotations

import inspect
import re
from pathlib import Path

import numpy as np
import pytest
import scipy.sparse as sp

import fvf

ROOT = Path(__file__).resolve().parents[1]
_CALL = re.compile(r"`(\w+)\(([^)]*)\)`")


def _section() -> str:
    text = (ROOT / "docs" / "conventions.md").read_text()
    start = text.index("## Names\n")
    return text[start : text.index("\n## ", start + 1)]


def _pairs() -> list[dict]:
    """The rows of the table: matrix and application as (name, [argument names]), and
    the shapes of the array and of the result."""
    rows = []
    for line in _section().splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) != 4 or "→" not in cells[3] or not _CALL.search(cells[1]):
            continue  # not a row of the table, or its header
        (matrix,), (applied,) = _CALL.findall(cells[1]), _CALL.findall(cells[2])
        given, result = (s.strip() for s in cells[3].split("→"))
        rows.append(
            {
                "matrix": (matrix[0], [a.strip() for a in matrix[1].split(",")]),
                "applied": (applied[0], [a.strip() for a in applied[1].split(",")]),
                "shapes": (given, result),
            }
        )
    return rows


PAIRS = _pairs()
IDS = [p["matrix"][0] for p in PAIRS]


def _required(fn) -> list[str]:
    """The parameters without a default, in order (what the operator needs)."""
    return [
        name
        for name, prm in inspect.signature(fn).parameters.items()
        if prm.default is inspect.Parameter.empty
        and prm.kind in (prm.POSITIONAL_ONLY, prm.POSITIONAL_OR_KEYWORD)
    ]


def _returns_sparse(fn) -> bool:
    ann = inspect.signature(fn).return_annotation
    text = ann if isinstance(ann, str) else getattr(ann, "__name__", str(ann))
    return bool(re.search(r"\bsp\.|sparray|csr_array|bsr_array|spmatrix", text))


def test_the_table_lists_the_pairs():
    assert IDS == [
        "grad",
        "div",
        "rotation",
        "vertex_to_face",
        "face_to_vertex",
        "ad",
    ], "docs/conventions.md, section Names: the table changed; update this list with it"


@pytest.mark.parametrize("pair", PAIRS, ids=IDS)
def test_matrix_and_application_have_the_documented_signatures(pair):
    (matrix, m_args), (applied, a_args) = pair["matrix"], pair["applied"]
    assert matrix != applied
    assert matrix in fvf.__all__ and applied in fvf.__all__
    assert _required(getattr(fvf, matrix)) == m_args, matrix
    assert _required(getattr(fvf, applied)) == a_args, applied
    # the application takes what the matrix takes, and the array it acts on
    assert a_args[: len(m_args)] == m_args and len(a_args) == len(m_args) + 1
    assert _returns_sparse(getattr(fvf, matrix)) and not _returns_sparse(getattr(fvf, applied))


def _shape(text: str, mesh: fvf.TriMesh) -> tuple[int, ...]:
    sizes = {"n": mesh.n_vertices, "m": mesh.n_faces}
    parts = [p.strip() for p in text.strip("()").split(",") if p.strip()]
    return tuple(sizes[p] if p in sizes else int(p) for p in parts)


def _array(shape: tuple[int, ...], mesh: fvf.TriMesh, rng) -> np.ndarray:
    x = rng.standard_normal(shape)
    return mesh.project_tangent(x) if shape == (mesh.n_faces, 3) else x


MESHES = {
    "jittered sphere": lambda: fvf.jittered_sphere(2, 0.3, seed=1),
    "torus": lambda: fvf.torus(12, 8),
    "disk (boundary)": lambda: fvf.disk(4, 6),
}


@pytest.mark.parametrize("mesh_name", list(MESHES))
@pytest.mark.parametrize("pair", PAIRS, ids=IDS)
def test_the_application_is_the_matrix_times_the_array(pair, mesh_name):
    mesh = MESHES[mesh_name]()
    rng = np.random.default_rng(3)
    (matrix, m_args), (applied, _) = pair["matrix"], pair["applied"]
    given, result = (_shape(s, mesh) for s in pair["shapes"])
    defining = [_array((mesh.n_faces, 3), mesh, rng) for _ in m_args[1:]]  # the field v
    x = _array(given, mesh, rng)
    M = getattr(fvf, matrix)(mesh, *defining)
    y = getattr(fvf, applied)(mesh, *defining, x)
    assert sp.issparse(M) and M.shape == (int(np.prod(result)), int(np.prod(given)))
    assert type(y) is np.ndarray and y.dtype == np.float64 and y.shape == result
    expected = (M @ x.reshape(-1)).reshape(result)
    scale = max(float(np.abs(expected).max()), 1.0)
    assert np.abs(y - expected).max() <= 1e-12 * scale, (matrix, applied)


def _public_sparse_functions() -> set[str]:
    names = set()
    for name in fvf.__all__:
        obj = getattr(fvf, name)
        if inspect.isfunction(obj) and _returns_sparse(obj):
            names.add(name)
    return names


def test_every_public_function_returning_a_sparse_array_is_named_in_the_section():
    named = set(re.findall(r"`(\w+)(?:\(|`)", _section()))
    found = _public_sparse_functions()
    assert len(found) > 20, sorted(found)  # the annotation reader sees them
    missing = sorted(found - named)
    assert not missing, (
        f"fvf functions returning sparse arrays not named in docs/conventions.md, section "
        f"Names (say whether each has an application): {missing}"
    )
    # and what the section names as a matrix exists and returns one
    for name in ("laplacian", "stiffness", "D_V", "bracket_F", "acap_energy_matrix"):
        assert name in named and _returns_sparse(getattr(fvf, name)), name


def test_an_operators_name_never_returns_an_array_for_one_call_and_a_matrix_for_another():
    """Each public name returns one kind: the matrices of the table take no array, and
    no application is also reachable under a matrix's name (nor the other way round)."""
    matrices = {p["matrix"][0] for p in PAIRS} | _public_sparse_functions()
    applications = {p["applied"][0] for p in PAIRS}
    assert not matrices & applications
    for name in applications:
        assert getattr(fvf, name) is not None and not _returns_sparse(getattr(fvf, name))
    for name in matrices:  # one object per name: no alias of an application
        assert all(getattr(fvf, name) is not getattr(fvf, a) for a in applications)
