"""The demo: the chapter's story end to end on one mesh, as run by ``fvf demo``.

It contains no math: every number comes from a library call.
"""

from __future__ import annotations

import json
import time
from pathlib import Path

import numpy as np

__all__ = ["demo"]

_PICTURES = "pictures (Figs. 3, 7, 9-12) -- needs rendering (fvf.viz), not built yet"


def _stage(name: str):
    print(f"[fvf demo] {name} ...", flush=True)
    return time.perf_counter()


def demo(mesh_path: str | None, out: Path) -> dict:
    """Run the chapter's story on a mesh and write ``summary.json`` into ``out``."""
    import fvf

    t0 = _stage("loading mesh")
    mesh = fvf.TriMesh(*fvf.read_mesh(mesh_path)) if mesh_path else fvf.examples.spot()
    X = mesh.vertices
    out.mkdir(parents=True, exist_ok=True)
    report: dict = {
        "mesh": mesh_path or "built-in spot.obj",
        "n_vertices": mesh.n_vertices,
        "n_faces": mesh.n_faces,
        "euler_characteristic": mesh.euler_characteristic,
    }

    _stage("discrete calculus and identities (section 3.1)")
    Dv, L = fvf.div(mesh), fvf.laplacian(mesh)
    h = X[:, 1] + 0.5 * np.sin(3 * X[:, 0] / np.ptp(X[:, 0]))
    v = fvf.rotate(mesh, fvf.gradient(mesh, h))  # v = J grad h: divergence-free
    w = fvf.gradient(mesh, X[:, 0])
    report["max |div J grad h| / max |div|"] = float(
        np.abs(Dv @ v.ravel()).max() / np.abs(Dv).max() / np.abs(v).max()
    )
    report["max |D^F_v X - v| (Lemma 9)"] = float(
        np.abs(fvf.extract_field(mesh, fvf.D_F(mesh, v)) - v).max()
    )
    report["L has constants in its kernel"] = float(np.abs(L @ np.ones(mesh.n_vertices)).max())

    _stage("brackets (eqs. 46, 54)")
    u = fvf.commutator_field(mesh, v, w)
    report["commutator field |D^F_[v,w] X| mean"] = float(np.linalg.norm(u, axis=1).mean())
    report["vertex bracket nnz (2-ring)"] = int(fvf.bracket_V(mesh, v, w).nnz)
    report["mixed bracket nnz (1-ring)"] = int(fvf.bracket_F(mesh, v, w).nnz)

    _stage("functional flow exp(-t D^V_v) (section 3.5)")
    phi = fvf.FunctionalFlow(mesh, v)
    f0 = np.sin(4 * X[:, 2] / np.ptp(X[:, 2]))
    times = np.linspace(0.0, 1.0, 5) * np.ptp(X[:, 0]) / np.abs(v).max()
    frames = phi(f0, times)
    report["flow times"] = times.tolist()
    report["relative A_V-norm drift of J grad h flow"] = float(
        abs(phi.norm(frames[-1]) - phi.norm(f0)) / phi.norm(f0)
    )
    _stage("ideal fluid by vorticity transport (Azencot et al. 2014)")
    Xc = (X - X.mean(0)) / np.linalg.norm(X - X.mean(0), axis=1).max()
    omega0 = np.exp(-10 * ((Xc - Xc[Xc[:, 2].argmax()]) ** 2).sum(1)) - np.exp(
        -10 * ((Xc - Xc[Xc[:, 0].argmin()]) ** 2).sum(1)
    )
    dt = fvf.fluid_time_step(mesh, omega0, 0.5)
    fluid = fvf.ideal_fluid(mesh, omega0, dt, 200, method="spectral", save_every=20)
    drift = fluid.drift()
    report["fluid energy drift (200 steps)"] = float(drift["energy"])
    report["fluid enstrophy drift (200 steps)"] = float(drift["enstrophy"])

    _stage("monotone (upwind) flow of a compressible field")
    g = fvf.gradient(mesh, X[:, 0])
    up = fvf.flow(mesh, g / np.abs(g).max(), f0, times, method="upwind")
    report["upwind flow stays in [min f0, max f0]"] = bool(
        up.min() >= f0.min() - 1e-12 and up.max() <= f0.max() + 1e-12
    )
    np.savez(out / "fluid.npz", vorticity=fluid.vorticity, times=fluid.times)

    _stage("Lie brackets on Laplace-Beltrami eigenfunctions (Fig. 7)")
    basis = fvf.SpectralBasis(mesh, 12)
    rV, rF = fvf.bracket_smoothness(mesh, v, w, basis.eigenvectors[:, 1:])
    report["Fig. 7 roughness vertex/mixed bracket (median)"] = float(np.median(rV / rF))

    _stage("commutation-guided rescaling (Fig. 10)")
    fr = fvf.rescale(mesh, v, w, 10.0)
    fw = (fvf.vertex_to_face(mesh) @ fr)[:, None] * w
    a = mesh.vertex_areas
    b0, b1 = fvf.bracket_norm(mesh, v, w), fvf.bracket_norm(mesh, v, fw)
    scale = np.sqrt(mesh.face_areas @ (w * w).sum(1) / (mesh.face_areas @ (fw * fw).sum(1)))
    report["Fig. 10 bracket L2 after/before rescaling"] = float(
        scale * np.sqrt(a @ b1**2) / np.sqrt(a @ b0**2)
    )

    _stage("as-commuting-as-possible fields and their singularities (Fig. 11)")
    acap = fvf.acap_fields(mesh, v, 1e-2, 2)
    report["Fig. 11 ACAP singularity counts"] = [len(fvf.singularities(mesh, u)[0]) for u in acap]

    _stage("interpolation of two fields along a flow (Fig. 12)")
    u0 = acap[0]
    u1 = fvf.Ad(mesh, v, u0, 0.5 * times[-1])
    mid = fvf.interpolate(mesh, v * 0.5 * times[-1], u0, u1, 0.5)
    report["Fig. 12 singularities: u0, transport midpoint, linear midpoint"] = [
        len(fvf.singularities(mesh, x, zero="warn")[0]) for x in (u0, mid, 0.5 * (u0 + u1))
    ]
    print(f"[fvf demo] skipped: {_PICTURES}", flush=True)
    report["skipped"] = [_PICTURES]
    (out / "summary.json").write_text(json.dumps(report, indent=2))
    np.savez(out / "flow.npz", vertices=X, faces=mesh.faces, f=frames, t=times, v=v)
    print(f"[fvf demo] done in {time.perf_counter() - t0:.1f}s; wrote {out}/summary.json")
    for key, val in report.items():
        if key not in ("flow times", "skipped"):
            print(f"  {key}: {val}")
    return report
