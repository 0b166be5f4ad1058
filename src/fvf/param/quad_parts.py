"""Connected components meshed one at a time by :func:`fvf.quad_mesh`, and joined again."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..mesh.trimesh import TriMesh
from ..numerics.summary import html_repr, short_repr
from .caps import Capped
from .quad_result import QuadMeshResult
from .quad_validity import QuadValidity, check_quad_mesh

__all__ = ["Part", "component_parts", "join_parts"]


@dataclass(frozen=True)
class Part:
    """One connected component of the input.

    Attributes
    ----------
    label : int
        Its label in ``mesh.vertex_components``.
    faces : int64 (m_c,)
        Its faces, as indices of the input's faces (in order).
    vertices : int64 (n_c,)
        Its vertices, as indices of the input's vertices (in order).
    mesh : TriMesh
        The component alone (vertex i is input vertex ``vertices[i]``).
    cap : Capped or None
        With boundary loops: the component closed by domes (:mod:`fvf.param.caps`).
    """

    label: int
    faces: np.ndarray
    vertices: np.ndarray
    mesh: TriMesh
    cap: Capped | None = None

    __repr__ = short_repr  # arrays by dtype and shape
    _repr_html_ = html_repr  # a table in Jupyter

    @property
    def closed(self) -> TriMesh:
        """The closed surface the parameterization is made on."""
        return self.mesh if self.cap is None else self.cap.mesh


def component_parts(mesh: TriMesh) -> list[Part]:
    """The connected components of ``mesh`` as separate meshes (one Part if connected)."""
    if mesh.n_components == 1:
        ids = np.arange(mesh.n_faces)
        return [Part(0, ids, np.arange(mesh.n_vertices), mesh)]
    label = mesh.vertex_components
    face_label = label[mesh.faces[:, 0]]
    parts = []
    for c in range(mesh.n_components):  # a loop over components, not faces
        faces = np.flatnonzero(face_label == c)
        verts = np.flatnonzero(label == c)
        local = np.full(mesh.n_vertices, -1, dtype=np.int64)
        local[verts] = np.arange(verts.size)
        sub = TriMesh(mesh.vertices[verts], local[mesh.faces[faces]])
        parts.append(Part(c, faces, verts, sub))
    return parts


def join_parts(mesh: TriMesh, made: list, dropped: list, h: float) -> QuadMeshResult:
    """One :class:`QuadMeshResult` from the meshed parts (vertices and quads stacked)."""
    Vs, Qs, vfs, params, surfaces, logs = [], [], [], [], [], []
    offset = 0
    for part, (V, Q, vf, param, surface, _verdict, log) in made:
        Vs.append(V)
        Qs.append(Q + offset)
        vfs.append(part.faces[vf])
        params.append(param)
        surfaces.append(surface)
        logs += [f"component {part.label}: {line}" for line in log]
        offset += V.shape[0]
    V = np.concatenate(Vs)
    Q = np.concatenate(Qs)
    if len(made) == 1:
        verdict = made[0][1][5]
    else:
        kept = np.concatenate([p.faces for p, _ in made])
        starts = np.cumsum([0] + [m[1].shape[0] for _, m in made[:-1]])
        folded = np.concatenate([m[5].folded + q0 for (_, m), q0 in zip(made, starts, strict=True)])
        verdict = _joint_verdict(mesh, kept, V, Q, folded)
    return QuadMeshResult(
        vertices=V,
        quads=Q,
        vertex_faces=np.concatenate(vfs).astype(np.int64),
        mesh=mesh,
        validity=verdict,
        parameterizations=tuple(params),
        surfaces=tuple(surfaces),
        components=np.array([p.label for p, _ in made], dtype=np.int64),
        dropped_components=np.array([p.label for p in dropped], dtype=np.int64),
        attempts=tuple(logs),
        edge_length=float(h),
        split_components=np.array([p.label for p, m in made if m[3] is None], dtype=np.int64),
    )


def _joint_verdict(
    mesh: TriMesh, kept: np.ndarray, V: np.ndarray, Q: np.ndarray, folded: np.ndarray
) -> QuadValidity:
    """The gate on the joined mesh, against the kept components of the input, with the
    folded quads each part's gate found (``folded``, int64: none; the fold test is the
    parts', and a split part's is its own, :mod:`fvf.param.split_quads`)."""
    F = mesh.faces[np.sort(kept)]
    used = np.unique(F)
    remap = np.full(mesh.n_vertices, -1, dtype=np.int64)
    remap[used] = np.arange(used.size)
    sub = mesh if used.size == mesh.n_vertices else TriMesh(mesh.vertices[used], remap[F])
    verdict = check_quad_mesh(sub, V, Q, folded=folded.astype(np.int64))
    if not verdict.valid:  # pragma: no cover - each part passed the same checks
        from ..errors import QuadMeshError

        raise QuadMeshError(f"the joined quad mesh is invalid: {verdict}")
    return verdict
