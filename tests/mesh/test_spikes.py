"""Spikes of a scan (:mod:`fvf.mesh.spikes`, :func:`fvf.flatten_spikes`): planted one-vertex
spikes on a noisy sphere are found exactly and flattened; smooth, noisy and CAD meshes
(corners fanned to a hole's rim) have none; ``fvf repair --despike``. (The spiky ball
meshed once flattened: ``tests/param/test_quad_failures.py``.)"""

from __future__ import annotations

import numpy as np
import pytest

import fvf
from corpus import spiky_ball
from fvf.mesh.shapes import icosphere, jittered_sphere, torus
from fvf.mesh.spikes import spike_vertices


def test_planted_spikes_are_found_and_flattened_exactly():
    V, F, tips = spiky_ball()
    assert np.array_equal(spike_vertices(V, F), tips)
    fixed = fvf.flatten_spikes(V, F)
    moved = np.flatnonzero(np.any(fixed.vertices != V, axis=1))
    assert np.array_equal(moved, tips)
    assert np.array_equal(fixed.faces, F) and np.array_equal(fixed.vertex_map, np.arange(len(V)))
    assert spike_vertices(fixed.vertices, F).size == 0
    r = np.linalg.norm(fixed.vertices[tips], axis=1)
    assert np.all(np.abs(r - 1) < 0.1)  # back on the noisy sphere
    assert "5 spike vertices" in fixed.log[0]


def test_smooth_noisy_and_cad_meshes_have_no_spikes():
    for mesh in (icosphere(3), jittered_sphere(3, jitter=0.3, seed=1), torus()):
        assert spike_vertices(mesh.vertices, mesh.faces).size == 0
    mf = pytest.importorskip("manifold3d")
    box = mf.Manifold.cube([40, 30, 20], True) - mf.Manifold.cylinder(30, 8, 8, 64, True)
    m = box.translate([0, 0, 0]).to_mesh64()
    V, F = np.asarray(m.vert_properties[:, :3], float), np.asarray(m.tri_verts, np.int64)
    assert spike_vertices(V, F).size == 0  # its corners are fanned to the hole's rim
    assert not fvf.flatten_spikes(V, F).changed


def test_fvf_repair_despike(tmp_path, capsys):
    from fvf.cli.main import main

    V, F, tips = spiky_ball()
    src, out = tmp_path / "ball.obj", tmp_path / "ball_fixed.obj"
    fvf.write_mesh(src, V, F)
    assert main(["repair", str(src), "-o", str(out), "--despike"]) == 0
    assert "flatten_spikes: moved 5 spike vertices" in capsys.readouterr().out
    W, G = fvf.read_mesh(out)[:2]
    assert spike_vertices(W, G).size == 0 and len(W) == len(V)
    assert main(["repair", str(src), "-o", str(tmp_path / "plain.obj")]) == 0
    assert spike_vertices(*fvf.read_mesh(tmp_path / "plain.obj")[:2]).size == tips.size
