"""Commuting frames: rescale_frame and frame_report."""

from __future__ import annotations

import numpy as np
import pytest

import fvf
from conftest import load_shared
from corpus import annulus


def _polar(mesh):
    c = mesh.face_centroids
    r = np.linalg.norm(c[:, :2], axis=1)
    e_r = np.stack([c[:, 0] / r, c[:, 1] / r, 0 * r], 1)
    return e_r, np.cross(mesh.face_normals, e_r)


def _slope(mesh, f):
    r = np.linalg.norm(mesh.vertices[:, :2], axis=1)
    return np.polyfit(np.log(r), np.log(f), 1)[0]


def test_polar_frame_scalings_are_the_coordinate_scalings():
    """Rotated gradient of f = r: u = e_θ = J∇r, v = J u = −e_r. The coordinate fields
    ∂_θ = r e_θ and ∂_r = e_r commute, so a ∝ r and b is constant (any b(r)·(−e_r)
    commutes with ∂_θ too; the smoothness term picks the constant)."""
    mesh = annulus(8, 64, 0.3)
    e_r, e_t = _polar(mesh)
    res = fvf.rescale_frame(mesh, e_t, -e_r)
    assert abs(_slope(mesh, res.a) - 1) < 0.03 and abs(_slope(mesh, res.b)) < 0.03
    assert res.after.bracket_energy < 0.02 * res.before.bracket_energy
    # the dual forms: θ¹ = dθ closes (it was r dθ); θ² = −dr was closed already
    assert res.after.curl_u < 0.05 * res.before.curl_u
    assert res.after.curl_v < 2 * res.before.curl_v < 1e-4


def test_polar_radial_frame():
    """u = e_r, v = e_θ: [a(r) e_r, r e_θ] = 0, the smoothness picks a constant a."""
    mesh = annulus(8, 64, 0.3)
    e_r, e_t = _polar(mesh)
    a, b = fvf.rescale_frame(mesh, e_r, e_t)
    assert abs(_slope(mesh, a)) < 0.1 and abs(_slope(mesh, b) - 1) < 0.03


def test_constant_frame_commutes_exactly():
    """Theorem 1: J∇x and J∇y have {x, y} = 1, so their mixed bracket vanishes at
    interior vertices; the scalings stay constant."""
    mesh = annulus(4, 32, 0.4)
    X = fvf.rotate(mesh, fvf.gradient(mesh, mesh.vertices[:, 0]))
    Y = fvf.rotate(mesh, fvf.gradient(mesh, mesh.vertices[:, 1]))
    rep = fvf.frame_report(mesh, X, Y)
    assert rep.bracket_energy < 1e-20 and rep.curl_u < 1e-10 and rep.curl_v < 1e-10
    res = fvf.rescale_frame(mesh, X, Y)
    np.testing.assert_allclose(res.a, 1.0, atol=1e-6)
    np.testing.assert_allclose(res.b, 1.0, atol=1e-6)


@pytest.mark.parametrize(
    "make",
    [
        pytest.param(lambda: fvf.torus(32, 16), id="torus"),
        pytest.param(lambda: load_shared("spot.obj"), id="spot"),
    ],
)
def test_rescaling_a_combed_cross_field_lowers_the_bracket(make):
    mesh = make()
    x = fvf.design_field(mesh, n=4, align="curvature")
    C = fvf.comb(mesh, x, 4)
    res = fvf.rescale_frame(mesh, C[0], C[1])
    assert (res.a > 0).all() and (res.b > 0).all()
    assert np.isfinite(res.a).all() and np.isfinite(res.b).all()
    assert res.after.bracket_energy < 0.1 * res.before.bracket_energy
    assert res.after.curl_u < res.before.curl_u and res.after.curl_v < res.before.curl_v
    assert res.before.seam_vertices == res.after.seam_vertices
    if mesh.genus == 1:
        assert res.before.seam_vertices == 0  # aligned torus cross field: no jumps at all
    # stronger smoothing: smoother, less commuting
    smooth = fvf.rescale_frame(mesh, C[0], C[1], alpha=1.0)
    assert smooth.after.bracket_energy >= res.after.bracket_energy
    W = fvf.stiffness(mesh)
    la, ls = np.log(res.a), np.log(smooth.a)
    assert ls @ (W @ ls) <= la @ (W @ la)


def test_frame_report_defaults_and_scale_invariance():
    mesh = fvf.torus(24, 12)
    x = fvf.design_field(mesh, n=4, align="curvature")
    rep = fvf.frame_report(mesh, x)
    rep2 = fvf.frame_report(mesh, x, fvf.rotate(mesh, x), np.ones(mesh.n_vertices), None)
    assert rep == rep2
    a = np.linspace(1, 2, mesh.n_vertices)
    r1 = fvf.frame_report(mesh, x, None, a)
    r2 = fvf.frame_report(mesh, x, None, 3 * a)
    assert np.isclose(r1.bracket_energy, r2.bracket_energy, rtol=1e-12)


def test_bad_frames():
    mesh = fvf.torus(24, 12)
    x = fvf.design_field(mesh, n=4, align="curvature")
    with pytest.raises(fvf.FrameError, match="parallel"):
        fvf.rescale_frame(mesh, x, 2 * x)
    y = x.copy()
    y[[4, 9]] = 0
    with pytest.raises(fvf.FrameError, match=r"faces \[4, 9\]"):
        fvf.rescale_frame(mesh, y)
    for alpha in (-1.0, np.nan, "x"):
        with pytest.raises(fvf.ParameterError, match="alpha"):
            fvf.rescale_frame(mesh, x, alpha=alpha)
