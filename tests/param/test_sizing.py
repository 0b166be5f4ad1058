"""Quads sized by curvature (fvf.param.sizing): the conformal scale, the parameterization
that follows it, and the quad meshes it makes possible."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import fvf
from fvf.param.sizing import MAX_REFINEMENT, curvature_log_scale, refinement
from test_quad_failures import FINGER_RADIUS, finger_on_a_ball


def test_a_surface_flatter_than_the_quads_keeps_one_size():
    mesh = fvf.icosphere(3)  # radius 1: a quad edge of 0.3 is a third of a radius
    s = curvature_log_scale(mesh, 0.3)
    assert s.shape == (mesh.n_vertices,) and np.all(s == 0.0)
    assert refinement(mesh, s) == 1.0


def test_a_finger_asks_for_quads_about_its_radius():
    V, F = finger_on_a_ball()
    mesh = fvf.TriMesh(V, F)
    h = 0.2
    s = curvature_log_scale(mesh, h)
    assert s.min() >= 0.0 and s.max() <= np.log(MAX_REFINEMENT) + 1e-12
    finger = (np.hypot(V[:, 0], V[:, 1]) < 2 * FINGER_RADIUS) & (V[:, 2] > 1.05)  # top, tip
    bottom = V[:, 2] < -0.5
    # quad edge h e^{-s} about the radius of curvature (0.06) on the finger, h on the ball
    assert np.median(h * np.exp(-s[finger])) == pytest.approx(FINGER_RADIUS, rel=0.6)
    assert np.all(s[bottom] < 0.05)
    assert 1.0 < refinement(mesh, s) < 2.0  # the finger is a small part of the area


def _uv_density(mesh: fvf.TriMesh, h: float, sizing) -> np.ndarray:
    """uv edges per h of surface on each face, float64 (m,)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", fvf.FlippedParameterizationWarning)
        p = fvf.seamless_parameterization(mesh, edge_length=h, sizing=sizing)
    e1, e2 = p.uv[:, 1] - p.uv[:, 0], p.uv[:, 2] - p.uv[:, 0]
    uv_area = 0.5 * np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0])
    return np.sqrt(uv_area / mesh.face_areas) * h


def test_the_parameterization_is_finer_where_the_sizing_asks():
    """The fitted map has more uv length per surface length on the finger when sized by
    curvature (1.5x measured; e^{s} = 2.2 asked, the fit is a least-squares compromise
    with the integer conditions) and the same on the ball."""
    V, F = finger_on_a_ball()
    mesh = fvf.TriMesh(V, F)
    h = 0.2
    uniform, sized = _uv_density(mesh, h, None), _uv_density(mesh, h, "curvature")
    c = V[F].mean(axis=1)
    finger = (np.hypot(c[:, 0], c[:, 1]) < 2 * FINGER_RADIUS) & (c[:, 2] > 1.0)
    ball = c[:, 2] < 0.0
    assert np.median(sized[ball]) == pytest.approx(np.median(uniform[ball]), rel=0.15)
    assert np.median(sized[finger]) > 1.3 * np.median(uniform[finger])


def test_sizing_needs_the_curvature_field_or_a_field():
    mesh = fvf.icosphere(2)
    with pytest.raises(fvf.ParameterError, match="align='curvature'"):
        fvf.seamless_parameterization(mesh, target_faces=100, align="smooth", sizing="curvature")
    with pytest.raises(fvf.ParameterError, match="sizing must be"):
        fvf.seamless_parameterization(mesh, target_faces=100, sizing="area")
    with pytest.raises(fvf.ParameterError, match="one value per vertex"):
        fvf.seamless_parameterization(mesh, target_faces=100, sizing=np.zeros(3))
