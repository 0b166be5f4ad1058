"""The result of :func:`fvf.quad_mesh`: the quads and everything a user asks of them."""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from ..errors import format_indices
from ..mesh.trimesh import TriMesh
from ..numerics.summary import html_repr, short_repr
from .quad_validity import QuadValidity
from .quality import QuadQuality, measured_quality
from .seamless import SeamlessParameterization

__all__ = ["QuadMeshResult"]


@dataclass(frozen=True, eq=False)
class QuadMeshResult:
    """A valid quad mesh made by :func:`fvf.quad_mesh` (``V, Q = result`` unpacks it).

    Attributes
    ----------
    vertices : float64 (k, 3)
        On the input surface.
    quads : int64 (q, 4)
        Counter-clockwise about the input's outward normal.
    vertex_faces : int64 (k,)
        The input face each quad vertex lies on.
    mesh : TriMesh
        The input triangle mesh.
    validity : QuadValidity
        The gate's verdict (always valid: an invalid mesh is never returned).
    parameterizations : tuple of SeamlessParameterization or None
        One per meshed component, each on the triangle mesh in ``surfaces``; None for a
        component in ``split_components``.
    surfaces : tuple of TriMesh
        The triangle mesh each parameterization lives on: the component itself, or its
        copy remeshed at the quad scale (:mod:`fvf.param.remesh`); for a split component,
        the triangles that were split.
    components : int64 (c,)
        Input component (label of ``mesh.vertex_components``) of each entry above.
    dropped_components : int64 (d,)
        Components left out as too small for the quad size (a
        :class:`fvf.SmallComponentWarning` named them).
    attempts : tuple of str
        What was tried, in order, and how each try ended.
    edge_length : float
        The target quad edge length h.
    split_components : int64 (s,)
        Components whose attempts all failed and whose triangles were split into three
        quads each (``fallback="split"``, :mod:`fvf.param.split_quads`): valid quads that
        follow no field.
    """

    vertices: np.ndarray
    quads: np.ndarray
    vertex_faces: np.ndarray
    mesh: TriMesh
    validity: QuadValidity
    parameterizations: tuple[SeamlessParameterization | None, ...]
    surfaces: tuple[TriMesh, ...]
    components: np.ndarray
    dropped_components: np.ndarray
    attempts: tuple[str, ...]
    edge_length: float
    split_components: np.ndarray

    __repr__ = short_repr  # arrays by dtype and shape
    _repr_html_ = html_repr  # a table in Jupyter

    def __iter__(self) -> Iterator[np.ndarray]:
        """``V, Q = fvf.quad_mesh(mesh)``: the vertices, then the quads."""
        yield self.vertices
        yield self.quads

    def __len__(self) -> int:
        return 2

    def __getitem__(self, i: int) -> np.ndarray:
        """``result[0]`` the vertices, ``result[1]`` the quads (as a pair)."""
        return (self.vertices, self.quads)[i]

    @property
    def parameterization(self) -> SeamlessParameterization:
        """The parameterization, when one component was meshed on the input itself."""
        from ..errors import ParameterError

        made = self.parameterizations[0]
        if len(self.parameterizations) == 1 and made is None:
            raise ParameterError(
                "this quad mesh has no parameterization: its triangles were split into quads "
                "(fallback='split', .split_components)"
            )
        if len(self.parameterizations) != 1 or self.surfaces[0] is not self.mesh or made is None:
            raise ParameterError(
                "this quad mesh has several parameterizations (several components or a "
                "remeshed surface): read .parameterizations and .surfaces"
            )
        return made

    @cached_property
    def quality(self) -> QuadQuality:
        """:func:`fvf.quad_quality` of the quads against the input (computed once; with the
        parameterization's figures when it lives on the input itself; the Hausdorff
        distances and folded quads those the validity gate measured, when it judged the
        whole input)."""
        on_input = len(self.parameterizations) == 1 and self.surfaces[0] is self.mesh
        p = self.parameterizations[0] if on_input else None  # (None when split)
        v = self.validity  # measured against the kept components: all of them, or not used
        whole = self.dropped_components.size == 0 and np.isfinite(v.one_sided).all()
        gate = (v.one_sided, v.folded.size) if whole else None
        return measured_quality(self.mesh, self.vertices, self.quads, None, p, gate)

    def summary(self) -> str:
        """One line: quads, irregular vertices, corner angles, Hausdorff distance, folds."""
        q = self.quality
        split = ""
        if self.split_components.size:
            split = (
                f"; components {format_indices(self.split_components)} split from triangles, "
                "following no field"
            )
        return (
            f"{q.n_quads} quads, {q.n_vertices} vertices, {100 * q.irregular_fraction:.1f} % "
            f"irregular, corner angle error median {q.angle_deviation_median:.1f}° "
            f"(p95 {q.angle_deviation_p95:.1f}°), Hausdorff "
            f"{self.validity.hausdorff:.2f} quad edges, {q.n_folded} folded, valid{split}"
        )
