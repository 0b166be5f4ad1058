"""The built-in batch tasks: each one library call, its arrays and its summary figures.

Each task, its library call and the arrays it stores:

- ``repair`` (mesh, before validation): :func:`fvf.repair_mesh`; ``repair_vertex_origin``,
  ``repair_face_origin``, ``repair_flipped``, ``repair_log``.
- ``info`` (mesh, before validation): :func:`fvf.mesh.diagnostics.mesh_report`;
  ``info_report`` (the report as a JSON string).
- ``basis`` (mesh): :func:`fvf.laplace_basis` with ``k``; ``eigenvalues`` (k,),
  ``eigenfunctions`` (n, k), one function per column (the library's layout).
- ``fields`` (mesh): :func:`fvf.design_field` (with ``n`` when it takes one); ``v`` (m, 3).
- ``singularities`` (mesh, after ``fields``): :func:`fvf.singularities` of ``v``;
  ``singularity_vertices``, ``singularity_indices``, ``singularity_positions``.
- ``fmap`` (pair): :func:`fvf.functional_map_from_bases` and :func:`fvf.map_quality` with
  ``k``; ``fmap`` (k, k), ``p2p`` (n_source,).
- ``match`` (pair): :func:`fvf.match` with ``k``; ``match_p2p`` (n_source,) and
  ``match_C`` (k, k), in the directions of ``fmap``.
- ``quad`` (mesh, when ``fvf.quad_mesh`` exists): what the function returns
  (:func:`output_of`), keys prefixed ``quad``.

Keys follow the data-file schema of the ``fvf`` command (``docs/cli.md``): `v` is a
per-face field and the `singularity_*` keys are those of ``fvf design``, so ``fvf render
MESH RESULT.npz --field v --singularities`` draws a result; `eigenfunctions` holds one
function per column, so ``--function "eigenfunctions[:,3]"`` draws one.
"""

from __future__ import annotations

import dataclasses
import json
from collections.abc import Callable, Mapping
from typing import Any

import numpy as np

import fvf

from ..errors import ParameterError
from .registry import MeshContext, PairContext, TaskOutput, accepts, register_task

__all__ = ["output_of"]


def _check_k(options: Mapping[str, Any]) -> None:
    k = options.get("k")
    if not isinstance(k, (int, np.integer)) or isinstance(k, bool) or k < 1:
        raise ParameterError(f"k (eigenpairs per mesh) must be an integer >= 1, not {k!r}")


def _n_keywords(func: Callable, options: Mapping[str, Any], what: str) -> dict:
    """``{"n": n}`` when an N-field is asked for and ``func`` takes ``n``; {} for n = 1."""
    n = options.get("n")
    if n is None or n == 1:
        return {}
    if accepts(func, "n"):
        return {"n": n}
    raise ParameterError(
        f"n = {n} asks for N-fields, but {what} of this fvf takes no n (only n = 1); "
        "drop --n or update fvf"
    )


def _check_n(options: Mapping[str, Any]) -> None:
    n = options.get("n")
    if n is not None and (not isinstance(n, (int, np.integer)) or isinstance(n, bool) or n < 1):
        raise ParameterError(f"n (field symmetry) must be an integer >= 1, not {n!r}")
    _n_keywords(fvf.design_field, options, "fvf.design_field")


def _check_singularities(options: Mapping[str, Any]) -> None:
    _check_n(options)
    _n_keywords(fvf.singularities, options, "fvf.singularities")


def _json(obj: Any) -> np.ndarray:
    return np.array(json.dumps(obj, default=str, sort_keys=True))


# ---------------------------------------------------------------------------- mesh tasks
@register_task("repair", raw=True, description="repair the file's arrays (fvf.repair_mesh)")
def repair(ctx: MeshContext) -> TaskOutput:
    """Weld, drop degenerate and duplicate faces, split non-manifold vertices, orient."""
    n0, m0 = len(ctx.vertices), len(ctx.faces)
    r = fvf.repair_mesh(ctx.vertices, ctx.faces)
    ctx.replace(r.vertices, r.faces)
    arrays = {
        "repair_vertex_origin": r.vertex_origin,
        "repair_face_origin": r.face_origin,
        "repair_flipped": r.flipped,
        "repair_log": np.array(r.log, dtype=str),
    }
    figures = {
        "steps": len(r.log),
        "vertices_delta": len(r.vertices) - n0,
        "faces_delta": len(r.faces) - m0,
    }
    return TaskOutput(arrays, figures)


@register_task("info", raw=True, description="validation report (what `fvf info` prints)")
def info(ctx: MeshContext) -> TaskOutput:
    """Every problem of the arrays, genus, boundary loops, components, smallest angle."""
    from ..mesh.diagnostics import mesh_report

    report = mesh_report(ctx.vertices, ctx.faces)
    figures = {"problems": len(report.get("problems", ()))}
    for key in ("genus", "boundary_loops", "components", "min_angle_deg"):
        if report.get(key) is not None:
            figures[key] = report[key]
    return TaskOutput({"info_report": _json(report)}, figures)


@register_task(
    "basis", options=("k",), check=_check_k, description="k Laplace-Beltrami eigenpairs (--k)"
)
def basis(ctx: MeshContext) -> TaskOutput:
    """The k smallest eigenpairs of the cotangent Laplacian, L φ = λ A_V φ."""
    lam, phi = fvf.laplace_basis(ctx.mesh, int(ctx.options["k"]))
    figures = {f"lambda_{i}": float(lam[i]) for i in range(1, min(4, lam.size))}
    return TaskOutput({"eigenvalues": lam, "eigenfunctions": np.ascontiguousarray(phi)}, figures)


@register_task(
    "fields", options=("n",), check=_check_n, description="smoothest field (fvf.design_field)"
)
def fields(ctx: MeshContext) -> TaskOutput:
    """The smoothest unit-L2 tangent field (an N-field when --n is given and supported)."""
    v = fvf.design_field(ctx.mesh, **_n_keywords(fvf.design_field, ctx.options, "design_field"))
    return TaskOutput({"v": np.asarray(v)})


@register_task(
    "singularities",
    needs=("fields",),
    options=("n",),
    check=_check_singularities,
    description="singular vertices of the field and their indices",
)
def singularities(ctx: MeshContext) -> TaskOutput:
    """Singular vertices of ``fields``' v, their indices and positions."""
    kw = _n_keywords(fvf.singularities, ctx.options, "singularities")
    ids, index = fvf.singularities(ctx.mesh, ctx.arrays["v"], zero="fill", **kw)
    arrays = {
        "singularity_vertices": ids,
        "singularity_indices": index,
        "singularity_positions": fvf.singularity_positions(ctx.mesh, ids, "vertex"),
    }
    figures = {"count": int(ids.size), "index_sum": float(np.sum(index))}
    return TaskOutput(arrays, figures)


# ---------------------------------------------------------------------------- pair tasks
@register_task(
    "fmap",
    kind="pair",
    options=("k",),
    check=_check_k,
    description="functional map of a given vertex map (pairs file's 3rd column, or identity)",
)
def fmap(ctx: PairContext) -> TaskOutput:
    """C (k, k): spectral coefficients on the target -> on the source, pulled back by the
    vertex map source -> target (fvf.functional_map_from_bases(target, source, map))."""
    k = int(ctx.options["k"])
    p2p = ctx.point_map()
    b_src = fvf.SpectralBasis(ctx.source.mesh, k)
    b_tgt = fvf.SpectralBasis(ctx.target.mesh, k)
    C = fvf.functional_map_from_bases(b_tgt, b_src, p2p)
    quality = fvf.map_quality(C, b_tgt.eigenvalues, b_src.eigenvalues)
    figures = {k_: v for k_, v in quality.items() if np.isscalar(v)}
    return TaskOutput({"fmap": C, "p2p": p2p}, figures)


# ---------------------------------------------------------------------------- adapters
def _storable(value: Any) -> np.ndarray | None:
    a = np.asarray(value) if not isinstance(value, np.ndarray) else value
    return a if a.dtype.kind in "biufcU" else None


def output_of(result: Any, prefix: str) -> TaskOutput:
    """A :class:`TaskOutput` from whatever a library function returns.

    An array becomes ``arrays[prefix]``; a tuple or list ``arrays[prefix_i]``; a mapping,
    dataclass, named tuple or object with attributes one entry per field: scalars become
    figures, arrays become ``arrays[prefix_field]``, a :class:`fvf.TriMesh` its
    ``prefix_field_vertices`` and ``prefix_field_faces``. Anything else is left out.
    """
    from ..mesh.trimesh import TriMesh

    if isinstance(result, np.ndarray):
        return TaskOutput({prefix: result})
    if isinstance(result, tuple) and hasattr(result, "_asdict"):
        items = result._asdict()
    elif isinstance(result, (tuple, list)):
        items = {str(i): v for i, v in enumerate(result)}
    elif isinstance(result, Mapping):
        items = dict(result)
    elif dataclasses.is_dataclass(result):
        items = {f.name: getattr(result, f.name) for f in dataclasses.fields(result)}
    else:
        items = {k: v for k, v in vars(result).items() if not k.startswith("_")}
    arrays, figures = {}, {}
    for key, value in items.items():
        if isinstance(value, TriMesh):
            arrays[f"{prefix}_{key}_vertices"] = value.vertices
            arrays[f"{prefix}_{key}_faces"] = value.faces
        elif isinstance(value, (bool, int, float, np.number)) and np.ndim(value) == 0:
            figures[key] = value.item() if isinstance(value, np.generic) else value
        elif (a := _storable(value)) is not None and a.ndim > 0:
            arrays[f"{prefix}_{key}"] = a
    return TaskOutput(arrays, figures)


@register_task(
    "match",
    kind="pair",
    options=("k",),
    check=_check_k,
    description="fvf.match: the vertex map source -> target (functional maps, ZoomOut to --k)",
)
def match(ctx: PairContext) -> TaskOutput:
    """The vertex map source → target that :func:`fvf.match` computes.

    ``match_p2p`` int64 (n_source,): for each source vertex a target vertex (the direction
    of the ``fmap`` task's ``p2p``); ``match_C`` float64 (k, k): the functional map from
    coefficients on the target to coefficients on the source. The arrays as read are
    passed, so meshes with non-manifold flaps (which :class:`fvf.TriMesh` rejects) match
    as :func:`fvf.match` documents.
    """
    k = int(ctx.options.get("k") or 200)  # fvf.match's default k
    r = fvf.match_result(
        (ctx.target.vertices, ctx.target.faces),
        (ctx.source.vertices, ctx.source.faces),
        k=k,
        k_fit=min(15, k),
    )
    figures = {f"seconds_{step}": float(t) for step, t in r.timings.items()}
    return TaskOutput({"match_p2p": r.p2p_21, "match_C": r.C_12}, figures)


def _check_quad(options: Mapping[str, Any]) -> None:
    q = options.get("quads")
    if q is not None and (not isinstance(q, (int, np.integer)) or isinstance(q, bool) or q < 1):
        raise ParameterError(f"quads (quads per mesh) must be an integer >= 1, not {q!r}")
    if options.get("fallback", "error") not in ("error", "split"):
        raise ParameterError(
            f"fallback must be 'error' or 'split', not {options.get('fallback')!r}"
        )


@register_task(
    "quad",
    options=("quads", "fallback"),
    check=_check_quad,
    description="quad mesh, as `fvf quad MESH --faces N` makes it (fvf.quad_mesh; --quads, "
    "--fallback)",
)
def quad(ctx: MeshContext) -> TaskOutput:
    """The quad mesh :func:`fvf.quad_mesh` makes with its own default cross field (curvature
    aligned at the scale of the quads), as ``fvf quad MESH --faces N`` does: ``quads``
    quads (default m / 10), and with ``fallback="split"`` the components whose attempts
    all fail split from triangles. The ``fields`` task's field is not used (a smoothest
    N-field has no quad-scale alignment).

    ``quad_vertices`` float64 (k, 3), ``quad_quads`` int64 (q, 4); figures: the scalars of
    :func:`fvf.quad_quality` (``n_quads``, ``irregular_fraction``, angle deviations,
    ``n_folded``, ``closed``, ``manifold``, ...) and ``split_components`` (how many
    components were split from triangles).
    """
    made = fvf.quad_mesh(
        ctx.mesh,
        target_faces=ctx.options.get("quads"),
        fallback=ctx.options.get("fallback") or "error",
    )
    quads = {"quad_vertices": made.vertices, "quad_quads": made.quads}
    figures = {**output_of(made.quality, "quad").figures}
    figures["split_components"] = int(made.split_components.size)
    return TaskOutput(quads, figures)
