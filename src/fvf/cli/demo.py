"""The demo: the chapter's story end to end on one mesh, as run by ``fvf demo``.

It contains no math: every number and every picture comes from a library call. Each
stage is one function below, a section of the report (:mod:`fvf.cli.report`):
``index.html`` shows each stage's numbers with what they should be and a ✓/✗ against
their tolerance, its pictures, and the stage function's source (the exact calls that
made them, read with :mod:`inspect`). Adding a section is one more stage function in
:data:`STAGES`. Pictures need the optional extra (``pip install 'fvf[viz]'``); without it
every stage still runs and reports its numbers, and its pictures are listed as skipped
with the reason.

Every file of the output folder is written atomically (:func:`fvf.io.atomic.atomic_path`),
one after the other: a demo interrupted mid-way leaves the files it had completed (each
whole) and no half-written one; ``summary.json`` and ``index.html`` come last, so their
presence means the run finished.
"""

from __future__ import annotations

import functools
import importlib.util
import json
import sys
import time
import warnings
from pathlib import Path
from types import SimpleNamespace
from typing import TYPE_CHECKING, Any

import numpy as np
import scipy.sparse as sp

from ..errors import FvfError, OutputError
from .report import Story, json_default, print_numbers, render_html, section_not_done, strict_json

if TYPE_CHECKING:
    from ..mesh.trimesh import TriMesh  # noqa: F401
    from ..param.seamless import SeamlessParameterization  # noqa: F401
from ..io.atomic import atomic_path, atomic_write_text, writable_folder

__all__ = ["demo"]

_INSTALL = "pip install 'fvf[viz]'"


def _stage(name: str) -> float:
    print(f"[fvf demo] {name} ...", flush=True)
    return time.perf_counter()


def _progress(i: int, n: int, label: str) -> None:
    """A one-line text progress bar, redrawn in place (``i`` of ``n`` done)."""
    width = 24
    full = int(round(width * i / max(n, 1)))
    end = "\n" if i >= n else ""
    print(f"\r    [{'#' * full}{'.' * (width - full)}] {i}/{n} {label}", end=end, flush=True)


def _viz_missing() -> str | None:
    for module in ("matplotlib", "PIL"):
        if importlib.util.find_spec(module) is None:
            return f"{module} is not installed: {_INSTALL} to get the pictures"
    return None


def _both_sides():
    """Two views, the second from the opposite side: a closed surface hides half of itself."""
    import fvf.viz

    return fvf.viz.two_sides()


def _directions(mesh, u):
    """Unit directions u/|u| per face: arrows of equal length show where a field points."""
    import fvf.viz

    return fvf.viz.unit_field(mesh, u)


# ---------------------------------------------------------------------------- stages
def _scaled(X: np.ndarray, axis: int) -> np.ndarray:
    """Coordinate ``axis`` of the vertices X (n, 3) over its extent, float64 (n,); on a
    mesh flat across that axis (a planar mesh has no z extent: 0/0) the coordinate of
    the largest extent instead."""
    extent = np.ptp(X, axis=0)
    if not extent[axis] > 1e-9 * extent.max():
        axis = int(np.argmax(extent))
    return X[:, axis] / max(float(extent[axis]), 1e-300)


def _calculus(s, story):
    """Section 3.1: the discrete calculus and its identities."""
    import fvf

    st = story.begin("Discrete calculus and identities (§3.1)", _calculus)
    mesh, X = s.mesh, s.mesh.vertices
    Dv, L = fvf.div(mesh), fvf.laplacian(mesh)
    s.h = X[:, 1] + 0.5 * np.sin(3 * _scaled(X, 0))
    s.v = fvf.rotate(mesh, fvf.gradient(mesh, s.h))  # v = J grad h: divergence-free
    s.w = fvf.gradient(mesh, X[:, 0])
    st.closed_check(
        mesh.is_closed,
        "max |div J grad h| / max |div|",
        float(np.abs(Dv @ s.v.ravel()).max() / np.abs(Dv).max() / np.abs(s.v).max()),
        expect=0.0,
        tol=1e-10,
        note="div J grad = 0 exactly (eq. 31): round-off only",
    )
    st.check(
        "max |D^F_v X - v| (Lemma 9)",
        float(np.abs(fvf.extract_field(mesh, fvf.D_F(mesh, s.v)) - s.v).max()),
        expect=0.0,
        tol=1e-10 * float(np.abs(s.v).max()),
        note="the operator of v recovers v (tolerance relative to max |v|)",
    )
    st.check(
        "L has constants in its kernel",
        float(np.abs(L @ np.ones(mesh.n_vertices)).max()),
        expect=0.0,
        tol=1e-13 * float(abs(L).sum(axis=1).max()),
        note="max |L 1| (tolerance relative to the largest row sum of |L|)",
    )
    story.picture(
        st,
        "fig03_field.png",
        mesh,
        "v = J grad h (arrows) over h, both sides",
        function=s.h,
        field=s.v,
        colorbar_label="h",
        view=_both_sides(),
        wide=True,
    )


def _brackets(s, story):
    """Eqs. 46 and 54: the commutator field and the sparsity of both brackets."""
    import fvf

    st = story.begin("Brackets (eqs. 46, 54)", _brackets)
    mesh = s.mesh
    s.u = fvf.commutator_field(mesh, s.v, s.w)
    st.check(
        "commutator field |D^F_[v,w] X| mean",
        float(np.linalg.norm(s.u, axis=1).mean()),
        above=0.0,
        note="per vertex, mesh units per unit time; v and w do not commute",
    )
    indptr, indices, _ = mesh.vertex_pattern  # the 1-ring from the edges, not L's nonzeros:
    n = mesh.n_vertices  # a cotangent weight is exactly 0 at a right angle (CAD parts)
    ring = sp.csr_array((np.ones(indices.size), indices, indptr), shape=(n, n))
    two_ring = int((ring @ ring).nnz)
    st.check(
        "vertex bracket nnz (2-ring)",
        int(fvf.bracket_V(mesh, s.v, s.w).nnz),
        at_most=two_ring,
        note=f"at most the 2-ring pattern's {two_ring} entries (eq. 46)",
    )
    st.check(
        "mixed bracket nnz (1-ring)",
        int(fvf.bracket_F(mesh, s.v, s.w).nnz),
        at_most=mesh.n_vertices + 2 * mesh.n_edges,
        note=f"at most the 1-ring pattern's n + 2E = {mesh.n_vertices + 2 * mesh.n_edges} "
        "entries (Lemma 16)",
    )


def _flow(s, story):
    """Section 3.5, Fig. 3: a function transported along v at several times, and LIC."""
    import fvf

    st = story.begin("Functional flow exp(-t D^V_v) and LIC (§3.5, Fig. 3)", _flow)
    mesh, X = s.mesh, s.mesh.vertices
    phi = fvf.FunctionalFlow(mesh, s.v)
    s.f0 = np.sin(4 * _scaled(X, 2))
    s.times = np.linspace(0.0, 1.0, 5) * np.ptp(X[:, 0]) / np.abs(s.v).max()
    frames = phi(s.f0, s.times)
    s.frames = frames
    st.info("flow times", s.times.tolist(), note="input: the times of the pictures below")
    st.closed_check(
        mesh.is_closed,
        "relative A_V-norm drift of J grad h flow",
        float(abs(phi.norm(frames[-1]) - phi.norm(s.f0)) / phi.norm(s.f0)),
        expect=0.0,
        tol=1e-10,
        note="v is divergence-free, so its flow preserves the A_V-norm",
    )
    if story.skip_reason is None:
        for i, t in enumerate(s.times):
            _progress(i, len(s.times), "flow pictures")
            story.picture(
                st,
                f"fig03_flow_{i}.png",
                mesh,
                f"f transported along v, t = {t:.3g}",
                function=frames[i],
                clim=(s.f0.min(), s.f0.max()),
                field=s.v,
                colorbar_label="f",
            )
        _progress(len(s.times), len(s.times), "flow pictures")
        import fvf.viz

        lic = fvf.viz.surface_lic(mesh, s.v)  # its own texture resolution
        story.picture(
            st,
            "fig03_lic.png",
            mesh,
            "LIC of v: noise averaged along its streamlines, both sides",
            texture=lic,
            view=_both_sides(),
            wide=True,
        )
    else:
        story.picture(st, "fig03_flow_*.png, fig03_lic.png", mesh, "")


def _fluid(s, story):
    """Ideal fluid by vorticity transport (Azencot et al. 2014) and the upwind flow."""
    import fvf

    st = story.begin("Ideal fluid and the monotone (upwind) flow", _fluid)
    mesh, X = s.mesh, s.mesh.vertices
    Xc = (X - X.mean(0)) / np.linalg.norm(X - X.mean(0), axis=1).max()
    omega0 = np.exp(-10 * ((Xc - Xc[Xc[:, 2].argmax()]) ** 2).sum(1)) - np.exp(
        -10 * ((Xc - Xc[Xc[:, 0].argmin()]) ** 2).sum(1)
    )
    dt = fvf.fluid_time_step(mesh, omega0, 0.5)
    fluid = fvf.ideal_fluid(mesh, omega0, dt, 200, method="spectral", save_every=20)
    drift = fluid.drift()
    st.check(
        "fluid energy drift (200 steps)",
        float(drift["energy"]),
        expect=0.0,
        tol=1e-9,
        note="relative; the spectral integrator conserves it",
    )
    st.check(
        "fluid enstrophy drift (200 steps)",
        float(drift["enstrophy"]),
        expect=0.0,
        tol=1e-9,
        note="relative; the spectral integrator conserves it",
    )
    g = fvf.gradient(mesh, X[:, 0])
    up = fvf.flow(mesh, g / np.abs(g).max(), s.f0, s.times, method="upwind")
    st.check(
        "upwind flow stays in [min f0, max f0]",
        bool(up.min() >= s.f0.min() - 1e-12 and up.max() <= s.f0.max() + 1e-12),
        equals=True,
        note="monotone: every value a convex average",
    )
    s.fluid = fluid
    story.picture(
        st,
        "fluid_vorticity.png",
        mesh,
        "vorticity after 200 fluid steps, both sides",
        function=fluid.vorticity[-1],
        cmap="RdBu_r",
        clim="symmetric",
        colorbar_label="vorticity",
        view=_both_sides(),
        wide=True,
    )


def _fig7(s, story):
    """Fig. 7: both Lie brackets applied to Laplace-Beltrami eigenfunctions."""
    import fvf

    st = story.begin("Lie brackets on Laplace-Beltrami eigenfunctions (Fig. 7)", _fig7)
    mesh = s.mesh
    basis = fvf.SpectralBasis(mesh, 12)
    rV, rF = fvf.bracket_smoothness(mesh, s.v, s.w, basis.eigenvectors[:, 1:])
    st.info(
        "Fig. 7 roughness vertex/mixed bracket (median)",
        float(np.median(rV / rF)),
        note="Dirichlet ratio of D^V_[v,w] phi over that of D^F_[v,w] phi, median over 11 "
        "eigenfunctions. The chapter's claim (mixed smoother: > 1) holds on irregular "
        "meshes; on fairly regular ones such as spot the vertex bracket measures smoother "
        "(0.25-0.87 on the shared meshes, docs/notes.md)",
    )
    phi6 = basis.eigenvectors[:, 6]
    gV = fvf.bracket_V(mesh, s.v, s.w) @ phi6
    gF = fvf.bracket_F(mesh, s.v, s.w) @ phi6
    story.picture(
        st,
        "fig07_fields.png",
        mesh,
        "the fields v = J grad h and w = grad x, both sides",
        field=[s.v, s.w],
        field_labels=["v", "w"],
        view=_both_sides(),
        wide=True,
    )
    for name, f, caption in (
        ("fig07_eigenfunction.png", phi6, "eigenfunction phi_6"),
        ("fig07_vertex_bracket.png", gV, "vertex bracket D^V_[v,w] phi_6 (eq. 46)"),
        ("fig07_mixed_bracket.png", gF, "mixed bracket D^F_[v,w] phi_6 (eq. 54)"),
    ):
        story.picture(
            st,
            name,
            mesh,
            caption,
            function=f,
            cmap="RdBu_r",
            clim="symmetric",
            colorbar_label=caption.split(" (")[0].split(", ")[0],
        )


def _fig9(s, story):
    """Fig. 9: the commutator field D^F_[v,w] X, averaged to faces for the arrows."""
    import fvf

    st = story.begin("Commutator field (Fig. 9)", _fig9)
    mesh = s.mesh
    u_faces = mesh.project_tangent(fvf.vertex_to_face(mesh) @ s.u)
    b = fvf.bracket_norm(mesh, s.v, s.w)
    st.info(
        "commutator field |D^F_[v,w] X| max",
        float(np.linalg.norm(s.u, axis=1).max()),
        note="per vertex: the largest value of the colours below (mean in the brackets' section)",
    )
    st.info(
        "commutator field |D^F_[v,w] X| median",
        float(np.median(b)),
        note="per vertex: the colours below; the arrows show its direction averaged to "
        "faces, at unit length",
    )
    story.picture(
        st,
        "fig09_commutator.png",
        mesh,
        "commutator [v, w]: direction (arrows, per face) over its norm (per vertex)",
        function=b,
        field=_directions(mesh, u_faces),
        colorbar_label="|D^F_[v,w] X|",
        view=_both_sides(),
        wide=True,
    )


def _fig10(s, story):
    """Fig. 10: commutation-guided rescaling of w, bracket norm before and after."""
    import fvf

    st = story.begin("Commutation-guided rescaling (Fig. 10)", _fig10)
    mesh, v, w = s.mesh, s.v, s.w
    fr = fvf.rescale(mesh, v, w, 10.0)
    fw = (fvf.vertex_to_face(mesh) @ fr)[:, None] * w
    a = mesh.vertex_areas
    b0, b1 = fvf.bracket_norm(mesh, v, w), fvf.bracket_norm(mesh, v, fw)
    scale = np.sqrt(mesh.face_areas @ (w * w).sum(1) / (mesh.face_areas @ (fw * fw).sum(1)))
    st.check(
        "Fig. 10 bracket L2 after/before rescaling",
        float(scale * np.sqrt(a @ b1**2) / np.sqrt(a @ b0**2)),
        below=1.0,
        note="|[v, f w]| over |[v, w]| in L2, f w scaled to the L2 norm of w",
    )
    from ..viz.colors import robust_limits

    lim = (0.0, robust_limits(b0, mesh.vertex_areas)[1])  # the same colours before / after
    story.picture(
        st,
        "fig10_rescaling.png",
        mesh,
        "rescaling function f and the rescaled field f w, both sides",
        function=fr,
        field=fw * scale,
        colorbar_label="f",
        view=_both_sides(),
        wide=True,
    )
    story.picture(
        st,
        "fig10_before.png",
        mesh,
        "|[v, w]| before",
        function=b0,
        clim=lim,
        colorbar_label="|[v, w]|",
    )
    story.picture(
        st,
        "fig10_after.png",
        mesh,
        "|[v, f w]| after (same L2 norm of f w as w)",
        function=scale * b1,
        clim=lim,
        colorbar_label="|[v, f w]|",
    )


def _fig11(s, story):
    """Fig. 11: as-commuting-as-possible fields and their singularities."""
    import fvf

    st = story.begin("As-commuting-as-possible fields and singularities (Fig. 11)", _fig11)
    mesh = s.mesh
    s.acap = fvf.acap_fields(mesh, s.v, 1e-2, 2)
    counts, sums = [], []
    for i, u in enumerate(s.acap):
        ids, ind = fvf.singularities(mesh, u, zero="fill")
        counts.append(len(ids))
        sums.append(float(np.sum(ind)))
        story.picture(
            st,
            f"fig11_acap_{i}.png",
            mesh,
            f"ACAP field {i}: directions and singularities, both sides",
            field=_directions(mesh, u),
            singularities=(fvf.singularity_positions(mesh, ids), ind),
            view=_both_sides(),
            wide=True,
        )
    st.info("Fig. 11 ACAP singularity counts", counts, note="per field; the pictures show them")
    if mesh.n_components > 1:  # each eigenfield lives on the part of smallest energy
        st.info(
            "Fig. 11 sum of singularity indices",
            sums,
            note="Poincaré-Hopf holds for a field with no zero: an ACAP eigenfield of a "
            f"mesh of {mesh.n_components} parts may vanish on all but one",
        )
        return
    st.closed_check(
        mesh.is_closed,
        "Fig. 11 sum of singularity indices",
        sums,
        equals=[float(mesh.euler_characteristic)] * len(sums),
        note="Poincaré-Hopf: the Euler characteristic for every field",
    )


def _fig12(s, story):
    """Fig. 12: interpolation of two fields along the flow of v (eq. 68), on a sphere.

    u0, u1: gradients of two bumps at a0 = R_z(θ/2) e_x and a1 = R_z(−θ/2) e_x; v = θ e_z × x
    carries a0 to a1 in unit time. Their average has two maxima and a saddle on the near
    side; the transport interpolant has one maximum, moving along the equator.
    """
    import fvf

    st = story.begin("Interpolation of two fields along a flow (Fig. 12)", _fig12)
    mesh = fvf.icosphere(4)  # the scene needs a surface where the flow line is known
    X = mesh.vertices
    theta = 2.4
    u0, u1, v = fvf.examples.fig12_fields(mesh, theta, width=0.9)  # (m, 3) each
    ts = np.linspace(0.0, 1.0, 7)
    us = fvf.interpolate(mesh, v, u0, u1, ts)  # (7, m, 3)
    average = 0.5 * (u0 + u1)

    def near_side(u):  # singular vertices where the bumps are (x > 0), and their indices
        ids, ind = fvf.singularities(mesh, u, zero="warn")
        keep = X[ids, 0] > 0
        return ids[keep], ind[keep]

    st.info(
        "Fig. 12 scene",
        "icosphere(4), bumps 2.4 rad apart, v = 2.4 e_z x X",
        note="input: a sphere, where the flow line between the bumps is known",
    )
    st.check(
        "Fig. 12 singularities: u0, transport midpoint, linear midpoint",
        [len(near_side(x)[0]) for x in (u0, us[3], average)],
        equals=[1, 1, 3],
        note="on the bumps' side: one maximum; the average has two maxima and a saddle",
    )
    ids, _ = near_side(us[3])
    if len(ids):
        p = X[ids[0]]
        st.check(
            "Fig. 12 midpoint singularity: height z, angle/theta",
            [round(float(p[2]), 4), round(float(np.arctan2(p[1], p[0]) / theta), 4)],
            expect=[0.0, 0.0],
            tol=0.05,
            note="on the equator, halfway between the bumps (one edge is 0.03 theta)",
        )
    if story.skip_reason is not None:
        story.picture(st, "fig12_frame_*.png, fig12_strip.png, fig12_interpolation.gif", mesh, "")
        return
    import fvf.viz

    side = fvf.viz.View(azimuth=0.0, elevation=10.0, up="z")  # from +x: the bumps' side
    ids, ind = near_side(average)
    story.picture(
        st,
        "fig12_average.png",
        mesh,
        "average (u0 + u1)/2: two maxima and a saddle",
        field=_directions(mesh, average),
        singularities=(fvf.singularity_positions(mesh, ids), ind),
        view=side,
    )
    files = []
    for i, (t, u) in enumerate(zip(ts, us, strict=True)):
        _progress(i, len(ts), "interpolation frames")
        ids, ind = near_side(u)
        files.append(
            story.picture(
                st,
                f"fig12_frame_{i}.png",
                mesh,
                f"transport interpolation, t = {t:.2f}",
                field=_directions(mesh, u),
                singularities=(fvf.singularity_positions(mesh, ids), ind),
                size=(480, 360),
                view=side,
                listed=False,  # shown once, in the strip below
            )
        )
    _progress(len(ts), len(ts), "interpolation frames")
    _frame_grid(files, story.out / "fig12_strip.png")
    fvf.viz.write_gif(files + files[-2:0:-1], story.out / "fig12_interpolation.gif", fps=4)
    story.add_file(
        st,
        "fig12_strip.png",
        "transport interpolation u_t, t = 0 to 1, left to right and top to bottom",
        link="fig12_interpolation.gif",
    )


def _frame_grid(files: list, path: Path, cols: int = 4) -> None:
    """Write the pictures ``files`` (equal sizes) as one PNG at ``path``: a grid of
    ``cols`` columns, read left to right, top to bottom, white where no frame is left."""
    from PIL import Image

    frames = [Image.open(f).convert("RGB") for f in files]
    w, h = frames[0].width, frames[0].height
    grid = Image.new("RGB", (cols * w, -(-len(frames) // cols) * h), "white")
    for i, f in enumerate(frames):
        grid.paste(f, ((i % cols) * w, (i // cols) * h))
    with atomic_path(path) as tmp:
        grid.save(tmp, format="PNG")


def _cross_field(s, story):
    """Cross fields: a curvature-aligned 4-direction field and its singularities."""
    import fvf

    st = story.begin("A curvature-aligned cross field (N = 4)", _cross_field)
    mesh = s.mesh
    with warnings.catch_warnings(record=True) as caught:  # a flat mesh: no direction to follow
        warnings.simplefilter("always")
        s.cross = fvf.design_field(mesh, n=4, align="curvature")
    umbilic = [w for w in caught if issubclass(w.category, fvf.UnconstrainedComponentWarning)]
    for w in caught:  # the others as they were
        if w not in umbilic:
            warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
    ids, ind = fvf.singularities(mesh, s.cross, n=4)
    aligned = "aligned to principal curvature directions"
    if umbilic:  # (κ_1 − κ_2)² is zero on every face (a flat mesh)
        aligned = "the smoothest one (the surface is umbilic or flat: no principal direction)"
    story.picture(
        st,
        "cross_field.png",
        mesh,
        f"cross field {aligned}, singularities of index ±1/4",
        field=_directions(mesh, s.cross),
        n=4,
        singularities=(fvf.singularity_positions(mesh, ids), ind),
        view=_both_sides(),
        wide=True,
    )
    st.info("cross field singularities", len(ids), note="vertices of nonzero index")
    st.check(
        "cross field indices are multiples of 1/4",
        float(np.abs(4 * ind - np.round(4 * ind)).max(initial=0.0)),
        at_most=1e-9,
    )
    st.closed_check(
        mesh.is_closed,
        "cross field sum of indices",
        float(np.sum(ind)),
        expect=float(mesh.euler_characteristic),
        tol=1e-9,
        note="Poincaré-Hopf: the Euler characteristic",
    )


def _quads(s, story):
    """Fig. 1: a seamless parameterization along a cross field, and its quad mesh; beside
    Instant Meshes at the same quad count when it is installed."""
    import fvf
    from fvf.errors import ParameterizationInputError, QuadExtractionError
    from fvf.peers import has_instant_meshes, instant_meshes

    st = story.begin("A quad mesh from a cross field (Fig. 1)", _quads)
    mesh = s.mesh
    target = max(200, mesh.n_faces // 4)
    try:  # its own cross field: curvature-aligned at the scale of the quads
        made = fvf.quad_mesh(mesh, target_faces=target)
    except (ParameterizationInputError, QuadExtractionError) as exc:
        st.info("quad mesh", "not made", note=f"{type(exc).__name__}: {exc}"[:300])
        return
    V, Q, q = made.vertices, made.quads, made.quality
    params = [x for x in made.parameterizations if x is not None]  # (none split: no fallback)
    p, surface = params[0], made.surfaces[0]  # the first component's
    story.picture(
        st,
        "quads_checker.png",
        surface,
        f"seamless parameterization: {p.singular.size} cones on integer points",
        draw=functools.partial(_checkerboard, surface, p.uv),
        view=_both_sides(),
        wide=True,
    )
    story.picture(
        st,
        "quads.png",
        mesh,
        f"{Q.shape[0]} quads; irregular vertices by valence ({_irregular_valences(Q)})",
        draw=functools.partial(_quad_picture, V, Q),
        view=_both_sides(),
        wide=True,
    )
    st.info("quads", Q.shape[0], note=f"target {target}")
    flipped = int(sum(x.n_flipped for x in params))
    st.check("flipped uv triangles", flipped, equals=0)
    st.check(
        "quad mesh is manifold with the input's boundary and Euler characteristic",
        [q.closed == mesh.is_closed, q.manifold, q.euler_characteristic],
        equals=[True, True, mesh.euler_characteristic],
    )
    _quad_metrics(st, "fvf", q)
    if not has_instant_meshes():
        st.info("Instant Meshes", "not installed", note="pip install pynanoinstantmeshes")
        return
    Vi, Qi = instant_meshes(mesh, Q.shape[0])
    st.info("Instant Meshes: quads", Qi.shape[0], note="asked for as many as fvf made")
    _quad_metrics(st, "Instant Meshes", fvf.quad_quality(mesh, Vi, Qi))


def _irregular_valences(Q: np.ndarray) -> str:
    """The valences other than 4 in the quad mesh ``Q`` (q, 4): "3 and 5", "2, 3 and 5"."""
    from fvf.param.quality import quad_edges

    e = quad_edges(Q)[0]
    kinds = [str(k) for k in np.unique(np.bincount(e.ravel())) if k not in (0, 4)]
    return " and ".join([", ".join(kinds[:-1]), kinds[-1]] if len(kinds) > 1 else kinds or ["none"])


def _checkerboard(mesh, uv, path, **kwargs):
    import fvf.viz

    return fvf.viz.render_checkerboard(mesh, uv, path, **kwargs)


def _quad_picture(V, Q, path, **kwargs):
    import fvf.viz

    return fvf.viz.render_quads(V, Q, path, **kwargs)


def _quad_metrics(st: Any, who: str, q: Any) -> None:
    """The literature's quad-mesh metrics of one remesher, as rows of the report's table."""
    st.info(f"{who}: irregular vertex fraction", q.irregular_fraction, note="valence not 4")
    st.info(
        f"{who}: corner angle |θ − 90°| median, p95 (deg)",
        [q.angle_deviation_median, q.angle_deviation_p95],
        note="how square the quads are",
    )
    st.info(f"{who}: quad area std / mean", q.area_cv, note="how even their sizes are")
    st.info(
        f"{who}: Hausdorff to / from the input (bbox diagonal)",
        [q.hausdorff_to_input, q.hausdorff_from_input],
        note="one-sided distances between the surfaces",
    )


STAGES = (
    _calculus, _brackets, _flow, _fluid, _fig7, _fig9, _fig10, _fig11, _fig12, _cross_field,
    _quads,
)  # fmt: skip


# ---------------------------------------------------------------------------- report
_INTRO = (
    "<p>Under each section, its source: the exact calls that made its numbers and "
    "pictures. <code>s</code> carries the mesh and the fields from stage to stage, "
    "<code>st.check(...)</code> records a number with what it should be, "
    "<code>st.info(...)</code> an informative one, and "
    "<code>story.picture(st, name, mesh, caption, **options)</code> is "
    "<code>fvf.viz.render(mesh, OUT / name, title=caption, **options)</code> "
    "(<code>fvf.cli.report</code>).</p>"
)


def demo(
    mesh_path: str | None,
    out: Path,
    *,
    pictures: bool = True,
    size: tuple[int, int] = (600, 450),
    stages: tuple | None = None,
    up: str | None = None,
    dpi: int | None = None,
    view: tuple[float, float] | None = None,
) -> dict:
    """Run the chapter's story on a mesh; write ``summary.json``, pictures and ``index.html``.

    Parameters
    ----------
    mesh_path : str or None
        Mesh file (OBJ, OFF, PLY, STL, VTK, glTF); None for the built-in spot (2930
        vertices, 5856 faces).
    out : Path
        Output folder (created).
    pictures : bool
        Render the pictures (needs ``pip install 'fvf[viz]'``; without it they are
        reported as skipped and the numbers still come out).
    size : (int, int)
        Size of a one-view picture in pixels (two views side by side: 1.6 times as wide).
    stages : tuple of functions, optional
        The sections to run (default :data:`STAGES`, all of them; each reads what the
        earlier ones left in ``s``, so pass a prefix).
    up : {"x", "y", "z", "-x", "-y", "-z", "auto"}, optional
        The mesh axis up in every picture (default: detected,
        :func:`fvf.viz.camera.detect_up_axis`).
    dpi : int, optional
        Dots per inch recorded in the pictures (default 100).
    view : (float, float), optional
        Azimuth and elevation in degrees of every picture's camera (a picture of both
        sides keeps its second view opposite the first); default: each picture's own.

    Returns
    -------
    dict
        The content of ``summary.json``: the mesh, every number by its label, ``checks``
        (each number with what it should be and whether it is), ``checks_failed``,
        ``sections`` (the report's data), ``pictures`` (the pictures shown), ``files`` (all
        the pictures written), ``skipped`` (pictures not made, and why) and
        ``sections_not_done`` (sections this mesh did not allow: a typed fvf error, shown
        in the section's row "section not done"; the other sections still run).
    """
    import fvf

    out = writable_folder(out, "the demo's report")  # before any work: exit 5 at once
    t0 = _stage("loading mesh")
    mesh = fvf.TriMesh(*fvf.read_mesh(mesh_path)) if mesh_path else fvf.mesh.builtin.spot()
    report: dict = {
        "mesh": mesh_path or "built-in spot.obj",
        "n_vertices": mesh.n_vertices,
        "n_faces": mesh.n_faces,
        "euler_characteristic": mesh.euler_characteristic,
    }
    options = {
        k: v for k, v in (("up", up), ("dpi", dpi), ("view", view)) if v not in (None, "auto")
    }
    story = Story(out, pictures, size, _viz_missing(), options)
    if story.skip_reason is None:
        import fvf.viz

        backends = fvf.viz.available_backends()
        print(
            f"[fvf demo] pictures with {backends[0]} (available: {', '.join(backends)})", flush=True
        )
    else:
        print(f"[fvf demo] pictures skipped: {story.skip_reason}", flush=True)
    s = SimpleNamespace(mesh=mesh)
    not_done: list[str] = []
    for fn in STAGES if stages is None else stages:
        title = (fn.__doc__ or fn.__name__).splitlines()[0].rstrip(".")
        t, begun = _stage(title), len(story.stages)
        try:
            fn(s, story)
        except (FvfError, AttributeError) as exc:
            if isinstance(exc, OutputError) or (isinstance(exc, AttributeError) and not not_done):
                raise  # an output lost, or a bug (not a section needing one not done)
            not_done.append(section_not_done(story, fn, title, begun, exc))
        story.stages[-1].seconds = time.perf_counter() - t
    if not_done:
        report["sections_not_done"] = not_done
    checks = []
    for st in story.stages:
        for n in st.numbers:
            report[n.label] = n.value
            checks.append(
                {
                    "section": st.title,
                    "label": n.label,
                    "value": n.value,
                    "expect": n.expect,
                    "tol": n.tol,
                    "ok": n.ok,
                }
            )
    report["checks"] = checks
    report["checks_failed"] = sum(c["ok"] is False for c in checks)
    skipped = [x for st in story.stages for x in st.skipped]
    if skipped:
        report["skipped"] = skipped
        print(f"[fvf demo] skipped: {len(skipped)} picture(s): {story.skip_reason}", flush=True)
    report["pictures"] = [p["file"] for st in story.stages for p in st.pictures]
    report["files"] = list(story.files)
    report["backend"] = story.backend
    report["seconds"] = time.perf_counter() - t0
    report.update(story.as_dict())
    if hasattr(s, "fluid"):
        with atomic_path(out / "fluid.npz") as tmp:
            np.savez(tmp, vorticity=s.fluid.vorticity, times=s.fluid.times)
    if hasattr(s, "frames"):
        with atomic_path(out / "flow.npz") as tmp:
            np.savez(tmp, vertices=mesh.vertices, faces=mesh.faces, f=s.frames, t=s.times, v=s.v)
    text = json.dumps(strict_json(report), indent=2, default=json_default, allow_nan=False)
    atomic_write_text(out / "summary.json", text)
    atomic_write_text(out / "index.html", render_html(story, report, _INTRO))
    print(
        f"[fvf demo] done in {report['seconds']:.1f}s; wrote {out}/index.html, "
        f"{out}/summary.json and {len(report['files'])} pictures; "
        f"{sum(c['ok'] is True for c in checks)} of "
        f"{sum(c['ok'] is not None for c in checks)} checks pass"
    )
    print_numbers(story)
    sys.stdout.flush()
    return report
