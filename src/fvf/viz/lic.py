"""Line integral convolution: traced on the surface (:func:`surface_lic`), or the operator way.

:func:`surface_lic` is classical LIC on the surface at a resolution of its own: solid
white noise on a grid of texels (cubes of side ``diagonal / resolution``, independent of
the mesh) is averaged, with a Hann window, along streamlines traced exactly face to face
(:func:`fvf.viz.tracing.trace`) from every face of a canvas (the mesh split until its
edges are no longer than a texel), sampled twice per texel; the result is
histogram-equalized (contrast normalization). It returns a :class:`LicTexture` that
:func:`fvf.viz.render` draws with ``texture=``.

:func:`lic_texture` below is the chapter's construction (§3.5, Fig. 3), kept for what it
shows about flows: classical LIC averages a noise image along each streamline. With
functional vector fields the averaging is a flow of functions: transporting the noise N along v for
time s is ``Φ_{v,s} N`` (eq. 42 for the chapter's flow exp(−s D^V_v)), so the texture is

    T = (1 / 2L) ∫_{−L}^{L} Φ_{v̂,s} N ds,

the noise flowed forward and backward and averaged. v̂ = v / |v| is the unit field
(zero where v vanishes), so L is an arc length in mesh units and the streaks have the
same length everywhere. The integral is the trapezoid rule over ``samples`` equally
spaced times, all computed by one call of :func:`fvf.flows.dispatch.flow` (which chains the
times, so the work is that of flowing to ±L once).

Noise (:func:`lic_noise`): independent uniform values at the vertices (seeded), smoothed
by one implicit heat step ``(M + τ² K) N = M N_0`` with τ one mean edge length (M the
lumped mass, K the stiffness matrix, eq. 31): features about two edges wide, the finest
that the upwind flow carries without smearing them across the streamlines. A streak is
then about two edges wide and 2L long. On a coarse mesh, render the texture on a
subdivided copy (:func:`fvf.viz.subdivide`) for finer streaks; pass ``noise`` to use
another function.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from ..errors import FvfError
from ..flows.dispatch import flow
from ..mesh.convert import takes_mesh
from ..mesh.inputs import as_face_field, as_vertex_function
from ..mesh.shapes import midpoint_subdivision
from ..mesh.trimesh import TriMesh

__all__ = [
    "DEFAULT_LIC_LENGTH",
    "DEFAULT_LIC_RESOLUTION",
    "DEFAULT_LIC_STREAK",
    "LicTexture",
    "lic_noise",
    "lic_texture",
    "solid_noise",
    "surface_lic",
    "unit_field",
]

#: Default half-length L of the convolution of :func:`lic_texture`, in mean edge lengths.
DEFAULT_LIC_LENGTH = 12.0
#: Default texels across the bounding box's diagonal of :func:`surface_lic`.
DEFAULT_LIC_RESOLUTION = 300
#: Default half-length of :func:`surface_lic`'s streaks, in texels.
DEFAULT_LIC_STREAK = 12.0
#: Noise samples per texel along a streamline.
SAMPLES_PER_TEXEL = 1.5
#: The canvas is split no further than this many faces.
MAX_CANVAS_FACES = 600_000
#: Seeding passes of :func:`surface_lic` (later ones start where no streamline came near).
LIC_PASSES = 4
#: Seeds traced together (bounds the memory of the tracer's arrays).
_CHUNK = 20_000


def solid_noise(points: npt.ArrayLike, cell: float, seed: int = 0) -> np.ndarray:
    """White noise in space: one uniform value per cube of side ``cell`` (hashed).

    Parameters
    ----------
    points : array_like (k, 3)
    cell : float
        Side of the cubes (the texel), in mesh units.
    seed : int

    Returns
    -------
    ndarray float64 (k,)
        Values in [0, 1): the same for all points of one cube, independent between
        cubes (a splitmix64 hash of the cube's integer coordinates and the seed).
    """
    ijk = np.floor(np.asarray(points, dtype=float).reshape(-1, 3) / cell).astype(np.int64)
    z = ijk.astype(np.uint64)
    h = (
        z[:, 0] * np.uint64(0x9E3779B97F4A7C15)
        + z[:, 1] * np.uint64(0xC2B2AE3D27D4EB4F)
        + z[:, 2] * np.uint64(0x165667B19E3779F9)
        + np.uint64(int(seed) & 0xFFFFFFFF) * np.uint64(0xD6E8FEB86659FD93)
    )
    h = (h ^ (h >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
    h = (h ^ (h >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
    h = h ^ (h >> np.uint64(31))
    return (h >> np.uint64(11)).astype(np.float64) / float(2**53)


@dataclass(frozen=True)
class LicTexture:
    """A LIC texture on a canvas: the mesh split into faces no larger than a texel.

    Attributes
    ----------
    mesh : TriMesh
        The canvas: ``levels`` midpoint subdivisions of the source mesh (the same
        surface).
    values : ndarray float64 (n_c,)
        Grey level per canvas vertex in [0, 1] (histogram-equalized).
    parent : ndarray int64 (m_c,)
        The source face each canvas face lies in.
    levels : int
        Subdivisions from the source mesh to the canvas.
    texel : float
        Side of the noise's cubes, in mesh units.
    length : float
        Half-length L of the convolution, in mesh units.
    source_faces : ndarray int64 (m, 3)
        The source mesh's faces (to carry vertex functions over to the canvas).
    """

    mesh: TriMesh
    values: np.ndarray
    parent: np.ndarray
    levels: int
    texel: float
    length: float
    source: np.ndarray

    @property
    def source_faces(self) -> int:
        """Number of faces of the mesh the texture was computed on."""
        return int(self.source.shape[0])

    def vertex_values(self, f: npt.ArrayLike) -> np.ndarray:
        """A function per source vertex (n,) carried to the canvas vertices, linearly."""
        vals = np.zeros((np.asarray(f).shape[0], 3))
        vals[:, 0] = np.asarray(f, dtype=float)
        F = self.source
        for _ in range(self.levels):
            vals, F = midpoint_subdivision(vals, F)
        return vals[:, 0]


def _canvas(mesh: TriMesh, texel: float) -> tuple[TriMesh, np.ndarray, int, np.ndarray]:
    """The mesh split until its median edge is at most a texel (within MAX_CANVAS_FACES).

    Returns the canvas, the source face of each canvas face, the number of levels, and
    ``grid`` (m, N+1, N+1) int64 with N = 2^levels: the canvas vertex at barycentric
    coordinates ``(i, j, N − i − j) / N`` of source face t (corners 0, 1, 2), −1 where
    ``i + j > N``. It is built level by level exactly as :func:`midpoint_subdivision`
    numbers the midpoints.
    """
    E = mesh.edges
    median = float(
        np.median(np.linalg.norm(mesh.vertices[E[:, 0]] - mesh.vertices[E[:, 1]], axis=1))
    )
    levels = max(0, int(np.ceil(np.log2(max(median / texel, 1.0)))))
    while levels and mesh.n_faces * 4**levels > MAX_CANVAS_FACES:
        levels -= 1
    X, F = np.asarray(mesh.vertices), np.asarray(mesh.faces)
    m = F.shape[0]
    grid = np.full((m, 2, 2), -1, dtype=np.int64)
    grid[:, 1, 0], grid[:, 0, 1], grid[:, 0, 0] = F[:, 0], F[:, 1], F[:, 2]
    parent = np.arange(m)
    for _ in range(levels):
        grid = _refine_grid(grid, F, X.shape[0])
        X, F = midpoint_subdivision(X, F)
        parent = np.tile(parent, 4)
    return (TriMesh(X, F) if levels else mesh), parent, levels, grid


def _refine_grid(grid: np.ndarray, F: np.ndarray, n: int) -> np.ndarray:
    """The barycentric grid of the next midpoint subdivision level (see :func:`_canvas`)."""
    a, b = F[:, [1, 2, 0]].ravel(), F[:, [2, 0, 1]].ravel()
    uniq = np.unique(np.minimum(a, b) * n + np.maximum(a, b))
    N = grid.shape[1] - 1
    M = 2 * N
    out = np.full((grid.shape[0], M + 1, M + 1), -1, dtype=np.int64)
    i, j = np.nonzero(np.add.outer(np.arange(M + 1), np.arange(M + 1)) <= M)
    even = (i % 2 == 0) & (j % 2 == 0)
    out[:, i[even], j[even]] = grid[:, i[even] // 2, j[even] // 2]
    i, j = i[~even], j[~even]
    # each odd lattice point is the midpoint of two neighbours of the coarse lattice
    ai = np.where(i % 2 == 1, (i - 1) // 2, i // 2)
    aj = np.where(
        (i % 2 == 1) & (j % 2 == 1), (j + 1) // 2, np.where(j % 2 == 1, (j - 1) // 2, j // 2)
    )
    bi = np.where(i % 2 == 1, (i + 1) // 2, i // 2)
    bj = np.where(
        (i % 2 == 1) & (j % 2 == 1), (j - 1) // 2, np.where(j % 2 == 1, (j + 1) // 2, j // 2)
    )
    va, vb = grid[:, ai, aj], grid[:, bi, bj]
    key = np.minimum(va, vb) * n + np.maximum(va, vb)
    out[:, i, j] = n + np.searchsorted(uniq, key)
    return out


def _samples(mesh, u, faces, points, length, h):
    """Points every ``h`` along the streamlines of the unit field u from the points.

    Returns positions (J, k, 3), the source face of each (J, k), whether the curve got
    there (J, k) and whether it stopped before ``length`` (k,) (at the boundary, a zero
    vector or a sink line).
    """
    from .tracing import trace

    P, S, _ = trace(mesh, u, faces, points, length)  # (s + 1, k, 3), (s, k)
    k = points.shape[0]
    dist = h * np.arange(1, int(round(length / h)) + 1)  # (J,)
    if P.shape[0] < 2:  # nothing moved
        shape = (dist.size, k)
        return (
            np.repeat(points[None], dist.size, 0),
            np.broadcast_to(faces, shape),
            np.zeros(shape, bool),
            np.ones(k, bool),
        )
    seg = np.linalg.norm(P[1:] - P[:-1], axis=2)  # (s, k)
    cum = np.cumsum(seg, axis=0)  # arc length at the end of each segment
    i = np.minimum((cum[:, None, :] < dist[None, :, None]).sum(0), seg.shape[0] - 1)
    ok = dist[:, None] <= cum[-1][None, :] * (1 + 1e-12)
    flat = i * k + np.arange(k)[None, :]
    s_f = seg.ravel()[flat]
    start = cum.ravel()[flat] - s_f
    frac = np.divide(dist[:, None] - start, s_f, out=np.zeros(flat.shape), where=s_f > 0)
    Pf = P.reshape(-1, 3)
    x = Pf[flat] + np.clip(frac, 0.0, 1.0)[..., None] * (Pf[flat + k] - Pf[flat])
    f = np.where(ok, S.ravel()[flat], np.asarray(faces)[None, :])
    return x, f, ok, cum[-1] < length * (1 - 1e-9)


def _convolve_streamlines(mesh, u, faces, points, L, texel, seed):
    """LIC values along streamlines through the seeds (2L each way).

    Every sample of a streamline gets the Hann-weighted mean of the noise over the
    samples within L of it. Returned are the positions, source faces and values of the
    samples whose window lies on the traced curve, or is cut only where the curve really
    stops.
    """
    from scipy.ndimage import convolve1d

    h = texel / SAMPLES_PER_TEXEL
    fx, ff, fok, fstop = _samples(mesh, u, faces, points, 2 * L, h)
    bx, bf, bok, bstop = _samples(mesh, -u, faces, points, 2 * L, h)
    J = fx.shape[0]
    X = np.concatenate([bx[::-1], points[None], fx])  # (2J + 1, k, 3), along the field
    Fc = np.concatenate([bf[::-1], np.asarray(faces)[None], ff])
    ok = np.concatenate([bok[::-1], np.ones((1, points.shape[0]), bool), fok])
    noise = np.where(ok, solid_noise(X.reshape(-1, 3), texel, seed).reshape(ok.shape), 0.0)
    taps = int(round(L / h))
    w = 0.5 * (1.0 + np.cos(np.pi * np.arange(-taps, taps + 1) / (taps + 1)))
    num = convolve1d(noise, w, axis=0, mode="constant")
    den = convolve1d(ok.astype(float), w, axis=0, mode="constant")
    pos = np.arange(-J, J + 1)[:, None]
    keep = ok & (den > 0)
    keep &= (pos + taps <= J) | fstop[None, :]
    keep &= (pos - taps >= -J) | bstop[None, :]
    return X[keep], Fc[keep], num[keep] / den[keep]


def _nearest_canvas_vertex(
    mesh: TriMesh, grid: np.ndarray, X: np.ndarray, faces: np.ndarray
) -> np.ndarray:
    """The canvas vertex nearest each point, through its barycentric grid position."""
    from ..calculus import hat_gradients

    G = hat_gradients(mesh)[faces]  # (k, 3, 3)
    nxt = mesh.vertices[mesh.faces[faces][:, [1, 2]]]  # vertex after corners 0 and 1
    b0 = np.einsum("kj,kj->k", G[:, 0], X - nxt[:, 0])
    b1 = np.einsum("kj,kj->k", G[:, 1], X - nxt[:, 1])
    N = grid.shape[1] - 1
    i = np.clip(np.rint(N * b0), 0, N).astype(np.int64)
    j = np.clip(np.rint(N * b1), 0, N).astype(np.int64)
    j = np.minimum(j, N - i)
    return grid[faces, i, j]


def _seed_points(
    canvas: TriMesh, parent: np.ndarray, verts: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """A source face and a point inside it for canvas vertices (nudged into one of their
    faces)."""
    corner_face = np.empty(canvas.n_vertices, dtype=np.int64)
    corner_face[canvas.faces.ravel()] = np.repeat(np.arange(canvas.n_faces), 3)
    f = corner_face[verts]
    p = 0.98 * canvas.vertices[verts] + 0.02 * canvas.face_centroids[f]
    return parent[f], p


def _first_per_cell(points: np.ndarray, side: float) -> np.ndarray:
    """Indices of one point per occupied cube of the given side."""
    cells = np.floor(points / side).astype(np.int64)
    _, first = np.unique(cells, axis=0, return_index=True)
    return np.sort(first)


def _splat(
    mesh: TriMesh,
    u: np.ndarray,
    canvas: TriMesh,
    parent: np.ndarray,
    grid: np.ndarray,
    L: float,
    texel: float,
    seed: int | None,
) -> np.ndarray:
    """T at every canvas vertex: the mean of the streamline samples nearest to it.

    Streamlines 4L long are seeded about three times as densely as needed to pass by every
    vertex once; then again from vertices no streamline came near (at most
    :data:`LIC_PASSES` passes); the few left take their nearest hit neighbour's value.
    """
    from scipy.spatial import cKDTree

    acc = np.zeros(canvas.n_vertices)
    hits = np.zeros(canvas.n_vertices)
    side = np.sqrt(4 * L * texel / 3.0)  # 3 streamlines per (4L x texel) of surface
    verts = _first_per_cell(canvas.vertices, side)
    for _ in range(LIC_PASSES):
        faces, points = _seed_points(canvas, parent, verts)
        for a in range(0, verts.size, _CHUNK):
            part = slice(a, a + _CHUNK)
            X, Fc, T = _convolve_streamlines(mesh, u, faces[part], points[part], L, texel, seed)
            near = _nearest_canvas_vertex(mesh, grid, X, Fc)
            acc += np.bincount(near, weights=T, minlength=acc.size)
            hits += np.bincount(near, minlength=acc.size)
        missed = np.flatnonzero(hits == 0)
        if missed.size <= 1e-3 * canvas.n_vertices:
            break
        verts = missed[_first_per_cell(canvas.vertices[missed], 2 * texel)]
    T = np.divide(acc, hits, out=np.zeros_like(acc), where=hits > 0)
    missed = hits == 0
    if missed.any() and not missed.all():
        _, near = cKDTree(canvas.vertices[~missed]).query(canvas.vertices[missed])
        T[missed] = T[~missed][near]
    return T


@takes_mesh
def surface_lic(
    mesh: TriMesh,
    v: npt.ArrayLike,
    *,
    resolution: int = DEFAULT_LIC_RESOLUTION,
    length: float | None = None,
    seed: int = 0,
) -> LicTexture:
    """Line integral convolution of a tangent field, at a resolution of its own.

    ``T(p) = Σ_j w_j N(x_p(s_j)) / Σ_j w_j`` over arc lengths ``s_j`` in ``[−L, L]``
    (:data:`SAMPLES_PER_TEXEL` per texel), where ``x_p`` is the streamline of ``v/|v|``
    through ``p`` (traced exactly from face to face), ``N`` the solid white noise
    :func:`solid_noise` (one value per cube of side ``texel = diagonal / resolution``) and
    ``w`` the Hann window ``½(1 + cos(π s / L))``. T is computed at the vertices of a
    canvas (the mesh split until its median edge is at most a texel, at most
    :data:`MAX_CANVAS_FACES` faces; where the canvas has more than 1.5 vertices per
    texel², at about one per texel² and copied to the nearest vertices) and
    histogram-equalized, so the streaks span the whole grey range. The grain is the
    texel whatever the mesh's resolution: a 5k-face and a 750k-face mesh of one shape
    give the same picture.

    Parameters
    ----------
    mesh : TriMesh
    v : array_like (m, 3)
        Tangent field per face; only its direction matters. Streamlines stop where it
        vanishes, at the boundary, and where neighbouring vectors point at each other.
    resolution : int
        Texels across the bounding box's diagonal (default 300: about two pixels per
        texel in an 800 x 600 picture).
    length : float, optional
        Half-length L of the streaks in mesh units (default
        :data:`DEFAULT_LIC_STREAK` texels).
    seed : int
        Seed of the noise.

    Returns
    -------
    LicTexture
        Draw it with ``fvf.viz.render(mesh, path, texture=lic)`` (with ``function=`` too,
        the texture darkens the colormap).

    Raises
    ------
    FvfError
        ``resolution`` below 16 or a non-positive ``length``.
    """

    if int(resolution) < 16:
        raise FvfError(f"resolution must be at least 16 texels; got {resolution!r}")
    u = unit_field(mesh, v)
    diag = float(np.linalg.norm(np.ptp(mesh.vertices, axis=0)))
    texel = diag / int(resolution)
    L = DEFAULT_LIC_STREAK * texel if length is None else float(length)
    if not L > 0:
        raise FvfError(f"length must be positive; got {length!r}")
    canvas, parent, levels, grid = _canvas(mesh, texel)
    T = _splat(mesh, u, canvas, parent, grid, L, texel, seed)
    from .colors import equalize

    values = equalize(T, canvas.vertex_areas)
    return LicTexture(canvas, values, parent, levels, texel, L, np.asarray(mesh.faces))


@takes_mesh
def unit_field(mesh: TriMesh, v: npt.ArrayLike, rtol: float = 1e-8) -> np.ndarray:
    """v / |v| per face, float64 (m, 3); zero where |v| ≤ rtol · max |v|."""
    v = as_face_field(mesh, v, "v")
    speed = np.sqrt((v * v).sum(1))
    keep = speed > rtol * speed.max() if speed.size else speed > 0
    return np.divide(v, speed[:, None], out=np.zeros_like(v), where=keep[:, None])


@takes_mesh
def lic_noise(mesh: TriMesh, seed: int = 0, smoothing: float = 1.0) -> np.ndarray:
    """Seeded vertex noise smoothed at ``smoothing`` mean edge lengths, float64 (n,).

    Uniform [0, 1) values N_0, then ``(M + τ² K) N = M N_0`` with
    τ = ``smoothing`` · mean edge length (M = :func:`fvf.vertex_mass`,
    K = :func:`fvf.stiffness`). ``smoothing=0`` returns N_0.
    """
    import scipy.sparse.linalg as sla

    from ..calculus import stiffness, vertex_mass

    N0 = np.random.default_rng(seed).random(mesh.n_vertices)
    if smoothing <= 0:
        return N0
    tau = smoothing * mesh.mean_edge_length
    M = vertex_mass(mesh)
    return sla.spsolve((M + tau**2 * stiffness(mesh)).tocsc(), M @ N0)


@takes_mesh
def lic_texture(
    mesh: TriMesh,
    v: npt.ArrayLike,
    *,
    length: float | None = None,
    samples: int = 25,
    seed: int = 0,
    noise: npt.ArrayLike | None = None,
    method: str = "upwind",
) -> np.ndarray:
    """The LIC texture of a field: noise averaged along its flow, ``(1/2L)∫ Φ_{v̂,s} N ds``.

    Parameters
    ----------
    mesh : TriMesh
    v : array_like (m, 3)
        Tangent field per face; only its direction matters (it is normalised).
    length : float, optional
        Half-length L of the convolution in mesh units (default
        :data:`DEFAULT_LIC_LENGTH` mean edge lengths).
    samples : int
        Number of flow times s_k = linspace(−L, L, samples) (odd counts include s = 0).
    seed : int
        Seed of the noise :func:`lic_noise` (ignored when ``noise`` is given).
    noise : array_like (n,), optional
        The function to convolve instead of the seeded white noise.
    method : {"upwind", "chapter", "skew", "cayley", "spectral"}
        The flow (:func:`fvf.flows.dispatch.flow`). ``"upwind"`` (default) is a convex
        combination of noise values at every time, so T stays in [min N, max N] and
        cannot blow up on any mesh. ``"chapter"`` is the chapter's exp(−s D^V_v)
        (eq. 42), sharper but it may warn (FlowGrowthWarning) for compressible fields,
        and the unit field of a divergence-free field is compressible.

    Returns
    -------
    ndarray float64 (n,)
        T at the vertices. :func:`fvf.viz.render` draws it in grey with ``texture=``,
        histogram-equalized.
    """
    if samples < 2:
        raise ValueError(f"samples must be at least 2; got {samples}")
    u = unit_field(mesh, v)
    L = DEFAULT_LIC_LENGTH * mesh.mean_edge_length if length is None else float(length)
    if noise is None:
        N = lic_noise(mesh, seed)
    else:
        N = as_vertex_function(mesh, noise, "noise")
    s = np.linspace(-L, L, samples)
    frames = flow(mesh, u, N, s, method=method)  # (samples, n)
    w = np.full(samples, 1.0)
    w[[0, -1]] = 0.5
    return (w @ frames) / w.sum()
