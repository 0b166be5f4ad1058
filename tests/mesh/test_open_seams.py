"""Joining open seams: a triangle soup becomes the surface it was cut from, and nothing
else is ever merged."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import fvf
from fvf.mesh.open_seams import weld_open_seams


def _soup(mesh):
    V, F = mesh.vertices, mesh.faces
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", fvf.DuplicateVertexWarning)
        return fvf.TriMesh(V[F].reshape(-1, 3), np.arange(3 * len(F)).reshape(-1, 3))


def test_a_soup_becomes_the_surface_it_was_cut_from():
    """Every face keeps its index and its three positions; the welded mesh is the
    icosphere's topology (closed, one component, χ = 2, as many vertices)."""
    ico = fvf.icosphere(2)
    soup = _soup(ico)
    welded, merged = weld_open_seams(soup)
    assert merged == soup.n_vertices - ico.n_vertices
    assert welded.is_closed and welded.n_components == 1 and welded.euler_characteristic == 2
    np.testing.assert_array_equal(welded.vertices[welded.faces], soup.vertices[soup.faces])


def test_interior_coincident_vertices_are_never_merged():
    """Two closed spheres touching at one point (coincident vertices, no boundary) and a
    mesh with nothing to join come back as they are."""
    a = fvf.icosphere(1)
    V = np.concatenate([a.vertices, a.vertices + 2 * a.vertices[0]])
    two = fvf.TriMesh(V, np.concatenate([a.faces, a.faces + a.n_vertices]))
    for mesh in (two, fvf.icosphere(1)):
        assert weld_open_seams(mesh) == (mesh, 0)


def test_a_weld_that_would_make_a_non_manifold_edge_is_refused():
    """Three triangles of a soup sharing one edge position: joining them would give an
    edge with three faces, so nothing is joined."""
    V = np.array(
        [[0, 0, 0], [1, 0, 0], [0.5, 1, 0], [0, 0, 0], [1, 0, 0], [0.5, 0, 1],
         [0, 0, 0], [1, 0, 0], [0.5, -1, 0.2]],
        dtype=float,
    )  # fmt: skip
    F = np.array([[0, 1, 2], [4, 3, 5], [6, 7, 8]])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", fvf.DuplicateVertexWarning)
        mesh = fvf.TriMesh(V, F)
    assert weld_open_seams(mesh) == (mesh, 0)


def test_quad_mesh_of_a_soup_meshes_the_joined_surface():
    """fvf.quad_mesh on a soup said so and meshed one closed surface (it used to mesh
    every triangle as a component of its own: minutes, then an invalid joined mesh)."""
    soup = _soup(fvf.icosphere(3))
    with pytest.warns(fvf.VerticesWeldedWarning, match="joined"):
        made = fvf.quad_mesh(soup, target_faces=300)
    assert made.validity.valid and made.mesh.is_closed and made.mesh.n_components == 1
    assert 200 <= len(made.quads) <= 400
