"""Inputs far finer than the quads: decimated to the quad scale, or used as they are."""

from __future__ import annotations

import sys

import numpy as np
import pytest

import fvf
import quadcheck
from fvf.param import quadmesh
from fvf.param.decimation import (
    MAX_TRIANGLES_PER_QUAD,
    TRIANGLES_PER_QUAD,
    decimated_for_quads,
    triangles_per_quad,
)
from test_quad_pipeline import box

pytest.importorskip("fast_simplification")


def _h_for(mesh: fvf.TriMesh, per_quad: float) -> float:
    """The quad edge at which ``mesh`` has ``per_quad`` triangles per quad."""
    return float(np.sqrt(per_quad * mesh.total_area / mesh.n_faces))


def test_a_fine_sphere_is_decimated_to_the_quad_scale_and_stays_on_the_sphere():
    S = fvf.icosphere(5)  # 20,480 triangles; 205 per quad at 100 quads
    h = np.sqrt(S.total_area / 100)
    D = decimated_for_quads(S, h)
    assert D is not None and D.is_closed and D.euler_characteristic == 2
    assert abs(triangles_per_quad(D, h) - TRIANGLES_PER_QUAD) < 0.1  # 7.99 measured
    off = np.abs(np.linalg.norm(D.vertices, axis=1) - 1.0)  # the unit sphere, exactly
    assert off.max() < 0.05 * h  # 0.026 h measured: far inside one quad edge


def test_only_inputs_over_the_threshold_are_decimated():
    S = fvf.icosphere(4)
    at = _h_for(S, MAX_TRIANGLES_PER_QUAD)
    assert decimated_for_quads(S, at * (1 - 1e-9)) is None
    assert decimated_for_quads(S, at * (1 + 1e-9)) is not None


def test_without_the_library_the_input_is_used(monkeypatch):
    S = fvf.icosphere(4)
    monkeypatch.setitem(sys.modules, "fast_simplification", None)  # import fails
    assert decimated_for_quads(S, _h_for(S, 40.0)) is None


@pytest.mark.parametrize(
    "bad",
    [
        lambda V, F, **k: (V, F[1:]),  # a hole: not closed
        lambda V, F, **k: (V, np.concatenate([F, F[:1]])),  # an edge of three faces
        lambda V, F, **k: (V, np.concatenate([F[:-1], F[-1:, [0, 0, 1]]])),  # zero area
        lambda V, F, **k: (V[:0], F[:0]),  # nothing left
        lambda V, F, **k: (_ for _ in ()).throw(ValueError("the library's own error")),
    ],
    ids=["open", "nonmanifold", "zero-area", "empty", "raises"],
)
def test_a_decimation_that_is_no_closed_manifold_is_not_used(monkeypatch, bad):
    import fast_simplification

    monkeypatch.setattr(fast_simplification, "simplify", bad)
    S = fvf.icosphere(4)
    assert decimated_for_quads(S, _h_for(S, 40.0)) is None


def test_a_second_component_made_by_the_decimation_is_refused(monkeypatch):
    import fast_simplification

    def split(V, F, **k):  # the sphere and a shifted copy: two components, chi 4
        return np.concatenate([V, V + 5.0]), np.concatenate([F, F + len(V)])

    monkeypatch.setattr(fast_simplification, "simplify", split)
    S = fvf.icosphere(3)
    assert decimated_for_quads(S, _h_for(S, 40.0)) is None
    two = fvf.TriMesh(*split(S.vertices, S.faces))
    monkeypatch.setattr(fast_simplification, "simplify", lambda V, F, **k: (V, F))
    assert decimated_for_quads(two, _h_for(two, 40.0)) is not None  # two asked, two made


def test_quad_mesh_runs_on_the_decimated_surface_and_returns_quads_on_the_input():
    S = fvf.icosphere(5)  # 20,480 triangles
    made = fvf.quad_mesh(S, target_faces=100)
    assert made.attempts[0].startswith("component 0: decimated surface")
    assert made.surfaces[0].n_faces < S.n_faces / 20
    report = quadcheck.check(S.vertices, S.faces, made.vertices, made.quads)
    assert report.valid, report  # judged against the input, not the decimated surface
    _, closest = fvf.param.quad_folds.closest_surface_points(S, made.vertices)
    assert np.abs(closest - made.vertices).max() < 1e-9  # on the input surface
    kept = fvf.quad_mesh(S, target_faces=100, remesh="never")  # the input as it is
    assert kept.attempts[0].startswith("component 0: input surface")
    assert kept.surfaces[0].n_faces == S.n_faces


def test_a_component_with_sharp_features_is_not_decimated(monkeypatch):
    """Quadric collapses move creases (on a CAD part they left two vertices at one
    corner): a box subdivided to 3,072 triangles, 77 per quad at 40 quads, is meshed on
    its input; the finer sphere is decimated."""
    calls = []

    def spy(mesh, h):
        calls.append(mesh.n_faces)
        return decimated_for_quads(mesh, h)

    monkeypatch.setattr(quadmesh, "decimated_for_quads", spy)
    V, F = box()
    for _ in range(4):
        V, F = fvf.mesh.shapes.midpoint_subdivision(V, F)
    fine_box = fvf.TriMesh(V, F)
    h = np.sqrt(fine_box.total_area / 40)
    assert triangles_per_quad(fine_box, h) > MAX_TRIANGLES_PER_QUAD
    made = fvf.quad_mesh(fine_box, target_faces=40)
    assert calls == [] and made.attempts[0].startswith("component 0: input surface")
    fvf.quad_mesh(fvf.icosphere(5), target_faces=100)
    assert calls == [20480]


@pytest.mark.slow
def test_the_750k_armadillo_is_valid_from_its_first_attempt_at_20000_quads():
    """The first attempt (the input decimated to 160,000 triangles) gives a valid mesh by
    ``quadcheck``. With libigl's exact closest points in the untangling's steps it moved
    104 quad vertices up to 1.2 quad edges away and failed at 1.5 quad edges (Hausdorff);
    the steps keep the local search."""
    from conftest import load_shared

    mesh = load_shared("armadillo_750k.ply")
    made = fvf.quad_mesh(mesh, target_faces=20000, retry=False)
    assert "decimated surface" in made.attempts[0]
    V, Q = np.asarray(made.vertices), np.asarray(made.quads)
    verdict = quadcheck.check(mesh.vertices, mesh.faces, V, Q)
    assert verdict.valid, verdict.summary()
