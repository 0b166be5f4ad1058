"""The demo: the chapter's story end to end on one mesh, as run by ``fvf demo``.

It contains no math: every number and every picture comes from a library call. Each
stage is one function below; ``index.html`` shows each stage's numbers, its pictures and
the stage function's source (the exact calls that made them, read with :mod:`inspect`).
Pictures need the optional extra (``pip install 'fvf[viz]'``); without it every stage
still runs and reports its numbers, and its pictures are listed as skipped with the
reason.

Every file of the output folder is written atomically (:func:`fvf.io.atomic.atomic_path`),
one after the other: a demo interrupted mid-way leaves the files it had completed (each
whole) and no half-written one; ``summary.json`` and ``index.html`` come last, so their
presence means the run finished.
"""

from __future__ import annotations

import html
import importlib.util
import inspect
import json
import sys
import time
from pathlib import Path
from types import SimpleNamespace
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from ..mesh.trimesh import TriMesh
from ..io.atomic import atomic_path, atomic_write_text

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


class _Story:
    """Collects stages (numbers, pictures, code) and renders pictures or records skips."""

    def __init__(self, out: Path, pictures: bool, size: tuple[int, int]):
        self.out, self.size = out, size
        self.skip_reason = None if pictures else "pictures were turned off (pictures=False)"
        if self.skip_reason is None:
            self.skip_reason = _viz_missing()
        self.stages: list[dict] = []
        self.backend: str | None = None

    def begin(self, title: str, fn: object) -> dict:
        st = {"title": title, "numbers": {}, "pictures": [], "skipped": [], "code": fn}
        self.stages.append(st)
        return st

    def picture(
        self, st: dict, name: str, mesh: TriMesh, caption: str, **kwargs: Any
    ) -> Path | None:
        """Render ``name`` into the output folder, or record why it was skipped."""
        if self.skip_reason is not None:
            st["skipped"].append(f"{name}: {self.skip_reason}")
            return None
        import fvf.viz

        kwargs.setdefault("size", self.size)
        info = fvf.viz.render(mesh, self.out / name, title=caption, **kwargs)
        self.backend = info.backend
        st["pictures"].append({"file": name, "caption": caption, "backend": info.backend})
        return info.path


def _robust(f: np.ndarray, signed: bool = True) -> tuple[float, float]:
    """Colour limits at the 99th percentile of |f|: a few spikes (e.g. at the ears'
    tips) must not wash out the rest of the picture."""
    lim = float(np.percentile(np.abs(f), 99)) or 1.0
    return (-lim, lim) if signed else (float(np.min(f)), float(np.percentile(f, 95)))


def _directions(mesh, u):
    """Unit directions u/|u| per face: arrows of equal length show where a field points."""
    import fvf.viz

    return fvf.viz.unit_field(mesh, u)


# ---------------------------------------------------------------------------- stages
def _calculus(s, story):
    """Section 3.1: the discrete calculus and its identities."""
    import fvf

    st = story.begin("Discrete calculus and identities (§3.1)", _calculus)
    mesh, X = s.mesh, s.mesh.vertices
    Dv, L = fvf.div(mesh), fvf.laplacian(mesh)
    s.h = X[:, 1] + 0.5 * np.sin(3 * X[:, 0] / np.ptp(X[:, 0]))
    s.v = fvf.rotate(mesh, fvf.gradient(mesh, s.h))  # v = J grad h: divergence-free
    s.w = fvf.gradient(mesh, X[:, 0])
    st["numbers"]["max |div J grad h| / max |div|"] = float(
        np.abs(Dv @ s.v.ravel()).max() / np.abs(Dv).max() / np.abs(s.v).max()
    )
    st["numbers"]["max |D^F_v X - v| (Lemma 9)"] = float(
        np.abs(fvf.extract_field(mesh, fvf.D_F(mesh, s.v)) - s.v).max()
    )
    st["numbers"]["L has constants in its kernel"] = float(
        np.abs(L @ np.ones(mesh.n_vertices)).max()
    )
    story.picture(
        st,
        "fig03_field.png",
        mesh,
        "v = J grad h (arrows) over h",
        function=s.h,
        field=s.v,
        colorbar_label="h",
    )


def _brackets(s, story):
    """Eqs. 46 and 54: the commutator field and the sparsity of both brackets."""
    import fvf

    st = story.begin("Brackets (eqs. 46, 54)", _brackets)
    mesh = s.mesh
    s.u = fvf.commutator_field(mesh, s.v, s.w)
    st["numbers"]["commutator field |D^F_[v,w] X| mean"] = float(np.linalg.norm(s.u, axis=1).mean())
    st["numbers"]["vertex bracket nnz (2-ring)"] = int(fvf.bracket_V(mesh, s.v, s.w).nnz)
    st["numbers"]["mixed bracket nnz (1-ring)"] = int(fvf.bracket_F(mesh, s.v, s.w).nnz)


def _flow(s, story):
    """Section 3.5, Fig. 3: a function transported along v at several times, and LIC."""
    import fvf

    st = story.begin("Functional flow exp(-t D^V_v) and LIC (§3.5, Fig. 3)", _flow)
    mesh, X = s.mesh, s.mesh.vertices
    phi = fvf.FunctionalFlow(mesh, s.v)
    s.f0 = np.sin(4 * X[:, 2] / np.ptp(X[:, 2]))
    s.times = np.linspace(0.0, 1.0, 5) * np.ptp(X[:, 0]) / np.abs(s.v).max()
    frames = phi(s.f0, s.times)
    s.frames = frames
    st["numbers"]["flow times"] = s.times.tolist()
    st["numbers"]["relative A_V-norm drift of J grad h flow"] = float(
        abs(phi.norm(frames[-1]) - phi.norm(s.f0)) / phi.norm(s.f0)
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
                max_arrows=500,
            )
        _progress(len(s.times), len(s.times), "flow pictures")
        import fvf.viz

        fine, v_fine, _ = fvf.viz.subdivide(mesh, s.v, levels=2)  # finer canvas for streaks
        assert v_fine is not None  # a field was given
        lic = fvf.viz.lic_texture(fine, v_fine, method="upwind")
        story.picture(
            st, "fig03_lic.png", fine, "LIC of v: noise averaged along its flow", texture=lic
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
    st["numbers"]["fluid energy drift (200 steps)"] = float(drift["energy"])
    st["numbers"]["fluid enstrophy drift (200 steps)"] = float(drift["enstrophy"])
    g = fvf.gradient(mesh, X[:, 0])
    up = fvf.flow(mesh, g / np.abs(g).max(), s.f0, s.times, method="upwind")
    st["numbers"]["upwind flow stays in [min f0, max f0]"] = bool(
        up.min() >= s.f0.min() - 1e-12 and up.max() <= s.f0.max() + 1e-12
    )
    s.fluid = fluid
    lim = float(np.abs(fluid.vorticity[-1]).max())
    story.picture(
        st,
        "fluid_vorticity.png",
        mesh,
        "vorticity after 200 fluid steps",
        function=fluid.vorticity[-1],
        cmap="RdBu_r",
        clim=(-lim, lim),
    )


def _fig7(s, story):
    """Fig. 7: both Lie brackets applied to Laplace-Beltrami eigenfunctions."""
    import fvf

    st = story.begin("Lie brackets on Laplace-Beltrami eigenfunctions (Fig. 7)", _fig7)
    mesh = s.mesh
    basis = fvf.SpectralBasis(mesh, 12)
    rV, rF = fvf.bracket_smoothness(mesh, s.v, s.w, basis.eigenvectors[:, 1:])
    st["numbers"]["Fig. 7 roughness vertex/mixed bracket (median)"] = float(np.median(rV / rF))
    phi6 = basis.eigenvectors[:, 6]
    gV = fvf.bracket_V(mesh, s.v, s.w) @ phi6
    gF = fvf.bracket_F(mesh, s.v, s.w) @ phi6
    for name, f, caption in (
        ("fig07_eigenfunction.png", phi6, "eigenfunction phi_6"),
        ("fig07_vertex_bracket.png", gV, "vertex bracket D^V_[v,w] phi_6 (eq. 46)"),
        ("fig07_mixed_bracket.png", gF, "mixed bracket D^F_[v,w] phi_6 (eq. 54)"),
    ):
        story.picture(st, name, mesh, caption, function=f, cmap="RdBu_r", clim=_robust(f))


def _fig9(s, story):
    """Fig. 9: the commutator field D^F_[v,w] X, averaged to faces for the arrows."""
    import fvf

    st = story.begin("Commutator field (Fig. 9)", _fig9)
    mesh = s.mesh
    u_faces = mesh.project_tangent(fvf.vertex_to_face(mesh) @ s.u)
    st["numbers"]["commutator field |D^F_[v,w] X| max"] = float(np.linalg.norm(s.u, axis=1).max())
    b = fvf.bracket_norm(mesh, s.v, s.w)
    story.picture(
        st,
        "fig09_commutator.png",
        mesh,
        "commutator [v, w]: directions over its norm",
        function=b,
        clim=_robust(b, signed=False),
        field=_directions(mesh, u_faces),
        colorbar_label="|D^F_[v,w] X|",
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
    st["numbers"]["Fig. 10 bracket L2 after/before rescaling"] = float(
        scale * np.sqrt(a @ b1**2) / np.sqrt(a @ b0**2)
    )
    lim = (0.0, _robust(b0, signed=False)[1])
    story.picture(
        st,
        "fig10_rescaling.png",
        mesh,
        "rescaling function f (w -> f w)",
        function=fr,
        field=fw * scale,
        max_arrows=600,
    )
    story.picture(st, "fig10_before.png", mesh, "|[v, w]| before", function=b0, clim=lim)
    story.picture(
        st,
        "fig10_after.png",
        mesh,
        "|[v, f w]| after (same L2 norm of f w as w)",
        function=scale * b1,
        clim=lim,
    )


def _fig11(s, story):
    """Fig. 11: as-commuting-as-possible fields and their singularities."""
    import fvf

    st = story.begin("As-commuting-as-possible fields and singularities (Fig. 11)", _fig11)
    mesh = s.mesh
    s.acap = fvf.acap_fields(mesh, s.v, 1e-2, 2)
    counts = []
    for i, u in enumerate(s.acap):
        ids, ind = fvf.singularities(mesh, u)
        counts.append(len(ids))
        story.picture(
            st,
            f"fig11_acap_{i}.png",
            mesh,
            f"ACAP field {i}: directions and singularities",
            field=_directions(mesh, u),
            max_arrows=900,
            singularities=(fvf.singularity_positions(mesh, ids), ind),
        )
    st["numbers"]["Fig. 11 ACAP singularity counts"] = counts


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
    u0, u1, v = fvf.mesh.builtin.fig12_fields(mesh, theta, width=0.9)  # (m, 3) each
    ts = np.linspace(0.0, 1.0, 7)
    us = fvf.interpolate(mesh, v, u0, u1, ts)  # (7, m, 3)
    average = 0.5 * (u0 + u1)

    def near_side(u):  # singular vertices where the bumps are (x > 0), and their indices
        ids, ind = fvf.singularities(mesh, u, zero="warn")
        keep = X[ids, 0] > 0
        return ids[keep], ind[keep]

    st["numbers"]["Fig. 12 scene"] = "icosphere(4), bumps 2.4 rad apart, v = 2.4 e_z x X"
    st["numbers"]["Fig. 12 singularities: u0, transport midpoint, linear midpoint"] = [
        len(near_side(x)[0]) for x in (u0, us[3], average)
    ]
    ids, _ = near_side(us[3])
    if len(ids):
        p = X[ids[0]]
        st["numbers"]["Fig. 12 midpoint singularity: height z, angle/theta"] = [
            round(float(p[2]), 4),
            round(float(np.arctan2(p[1], p[0]) / theta), 4),
        ]
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
        max_arrows=700,
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
                max_arrows=700,
                view=side,
            )
        )
    _progress(len(ts), len(ts), "interpolation frames")
    from PIL import Image

    frames = [Image.open(f).convert("RGB") for f in files]
    strip = Image.new("RGB", (sum(f.width for f in frames), frames[0].height), "white")
    x = 0
    for f in frames:
        strip.paste(f, (x, 0))
        x += f.width
    with atomic_path(story.out / "fig12_strip.png") as tmp:
        strip.save(tmp, format="PNG")
    st["pictures"].append({"file": "fig12_strip.png", "caption": "the frames side by side"})
    fvf.viz.write_gif(files + files[-2:0:-1], story.out / "fig12_interpolation.gif", fps=4)
    st["pictures"].append({"file": "fig12_interpolation.gif", "caption": "animated (GIF)"})


STAGES = (_calculus, _brackets, _flow, _fluid, _fig7, _fig9, _fig10, _fig11, _fig12)


# ---------------------------------------------------------------------------- report
def _html(report: dict, story: _Story) -> str:
    esc = html.escape
    parts = [
        "<!doctype html><html><head><meta charset='utf-8'><title>fvf demo</title><style>",
        "body{font-family:sans-serif;max-width:1200px;margin:2em auto;color:#222}",
        "figure{display:inline-block;margin:4px;vertical-align:top}",
        "figure img{max-width:380px;border:1px solid #ddd}figcaption{font-size:80%}",
        "table{border-collapse:collapse}td{border:1px solid #ccc;padding:2px 8px}",
        "pre{background:#f6f6f6;padding:8px;overflow-x:auto;font-size:80%}",
        ".skip{color:#a40}</style></head><body>",
        "<h1>fvf demo: operator-based tangent vector fields</h1>",
        f"<p>Mesh: {esc(str(report['mesh']))} ({report['n_vertices']} vertices, "
        f"{report['n_faces']} faces, Euler characteristic {report['euler_characteristic']}). "
        f"Rendered with: {esc(str(story.backend or 'nothing (pictures skipped)'))}. "
        f"Total time {report['seconds']:.1f} s.</p>",
        "<p>Under each stage, its source: the exact calls that made its numbers and "
        "pictures. <code>s</code> carries the mesh and the fields from stage to stage, "
        "<code>st['numbers']</code> collects the numbers, and "
        "<code>story.picture(st, name, mesh, caption, **options)</code> is "
        "<code>fvf.viz.render(mesh, OUT / name, title=caption, size="
        f"{story.size}, **options)</code> (see <code>fvf.demo</code>).</p>",
    ]
    for st in story.stages:
        parts.append(f"<h2>{esc(st['title'])}</h2><table>")
        for key, val in st["numbers"].items():
            if key == "flow times":
                val = ", ".join(f"{t:.4g}" for t in val)
            parts.append(f"<tr><td>{esc(key)}</td><td>{esc(str(val))}</td></tr>")
        parts.append(f"<tr><td>seconds</td><td>{st['seconds']:.2f}</td></tr></table>")
        for pic in st["pictures"]:
            parts.append(
                f"<figure><a href='{esc(pic['file'])}'><img src='{esc(pic['file'])}' "
                f"alt='{esc(pic['caption'])}'></a><figcaption>{esc(pic['file'])}: "
                f"{esc(pic['caption'])}</figcaption></figure>"
            )
        for skip in st["skipped"]:
            parts.append(f"<p class='skip'>skipped: {esc(skip)}</p>")
        code = inspect.getsource(st["code"])
        parts.append(
            f"<details><summary>the library calls</summary><pre>{esc(code)}</pre></details>"
        )
    parts.append("</body></html>")
    return "\n".join(parts)


def demo(
    mesh_path: str | None,
    out: Path,
    *,
    pictures: bool = True,
    size: tuple[int, int] = (640, 480),
) -> dict:
    """Run the chapter's story on a mesh; write ``summary.json``, pictures and ``index.html``.

    Parameters
    ----------
    mesh_path : str or None
        OBJ, OFF or PLY file; None for the built-in spot (2930 vertices, 5856 faces).
    out : Path
        Output folder (created).
    pictures : bool
        Render the pictures (needs ``pip install 'fvf[viz]'``; without it they are
        reported as skipped and the numbers still come out).
    size : (int, int)
        Size of each picture in pixels.

    Returns
    -------
    dict
        The numbers of ``summary.json`` (``"skipped"`` lists skipped pictures and why).
    """
    import fvf

    t0 = _stage("loading mesh")
    mesh = fvf.TriMesh(*fvf.read_mesh(mesh_path)) if mesh_path else fvf.mesh.builtin.spot()
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    report: dict = {
        "mesh": mesh_path or "built-in spot.obj",
        "n_vertices": mesh.n_vertices,
        "n_faces": mesh.n_faces,
        "euler_characteristic": mesh.euler_characteristic,
    }
    story = _Story(out, pictures, size)
    if story.skip_reason is None:
        import fvf.viz

        backends = fvf.viz.available_backends()
        print(
            f"[fvf demo] pictures with {backends[0]} (available: {', '.join(backends)})", flush=True
        )
    else:
        print(f"[fvf demo] pictures skipped: {story.skip_reason}", flush=True)
    s = SimpleNamespace(mesh=mesh)
    for fn in STAGES:
        t = _stage((fn.__doc__ or fn.__name__).splitlines()[0].rstrip("."))
        fn(s, story)
        story.stages[-1]["seconds"] = time.perf_counter() - t
    for st in story.stages:
        report.update(st["numbers"])
    skipped = [x for st in story.stages for x in st["skipped"]]
    if skipped:
        report["skipped"] = skipped
        print(f"[fvf demo] skipped: {len(skipped)} picture(s): {story.skip_reason}", flush=True)
    report["pictures"] = [p["file"] for st in story.stages for p in st["pictures"]]
    report["backend"] = story.backend
    report["seconds"] = time.perf_counter() - t0
    with atomic_path(out / "fluid.npz") as tmp:
        np.savez(tmp, vorticity=s.fluid.vorticity, times=s.fluid.times)
    with atomic_path(out / "flow.npz") as tmp:
        np.savez(tmp, vertices=mesh.vertices, faces=mesh.faces, f=s.frames, t=s.times, v=s.v)
    atomic_write_text(out / "summary.json", json.dumps(report, indent=2))
    atomic_write_text(out / "index.html", _html(report, story))
    print(
        f"[fvf demo] done in {report['seconds']:.1f}s; wrote {out}/index.html, "
        f"{out}/summary.json and {len(report['pictures'])} pictures"
    )
    for key, val in report.items():
        if key not in ("flow times", "skipped", "pictures"):
            print(f"  {key}: {val}")
    sys.stdout.flush()
    return report
