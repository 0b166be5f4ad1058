"""Shape correspondence in one call: :func:`match` (the vertex map), :func:`match_result`
(everything computed) and :func:`symmetry_map`.

The pipeline (each step public, in :mod:`.descriptors`, :mod:`.fmap_fit`, :mod:`.zoomout`):

1. Prepare each mesh as the user has it (a TriMesh, arrays (V, F) or a file): repair
   non-manifold edges and vertices and keep the one large piece, dropping specks
   (:func:`fvf.mesh.prepared.prepare_mesh`), scale it to unit area.
2. Laplace–Beltrami bases (:class:`fvf.SpectralBasis`) with k eigenpairs.
3. Wave kernel signatures on a common grid of log-energies, plus landmark WKS when
   corresponding landmarks are given, each column normalized in the A_V norm.
4. Fit a small functional map (``k_fit``, default 15) with descriptor preservation,
   Laplacian and descriptor commutativity, the orientation term on the functional vector
   fields D_{J grad f} of the descriptors (orientation-preserving between two shapes,
   orientation-reversing for a self-symmetry) and a penalty on C ᵀC − I
   (:func:`fvf.fit_functional_map`). A small map is fitted on purpose: the orientation
   term must fix the signs of the few eigenfunctions that distinguish left from right,
   and in a small basis no other term can outweigh it.
5. ZoomOut to k (:func:`fvf.zoomout`) on farthest-point samples, then the vertex map
   on all vertices; with ``check_symmetry`` (default), from two starts, the fitted map
   and its composition with mesh 1's left-right symmetry, and, when those two do not
   decide, from the fit at ``K_WIDE``, from the fit turned end for end and from the fit
   with the distances to the mirror image; the candidates are refined to ``K_CHOICE``,
   the one nearest to an isometry that carries the descriptors over, of the requested
   orientation, is kept (:mod:`.candidates`) and refined on to k.
6. Carry the map back to the vertices the user passed.
"""

from __future__ import annotations

import time
import warnings
from collections.abc import Iterator
from dataclasses import dataclass, field
from typing import Any, Literal, overload

import numpy as np
import numpy.typing as npt

from ..errors import (
    BasisSizeError,
    LandmarkError,
    NotEnoughEigenpairsError,
    ParameterError,
    format_indices,
)
from ..mesh.convert import MeshLike, input_arrays
from ..mesh.prepared import PreparedMesh, prepare_mesh
from ..mesh.trimesh import TriMesh
from ..numerics.budget import check_memory
from ..numerics.progress import ProgressCallback, make_progress
from ..numerics.summary import html_repr, short_repr
from .basis import SpectralBasis
from .candidates import (
    DECISIVE_CONFIDENCE,
    GEODESIC_SAMPLES,
    GeodesicProbe,
    MapCandidate,
    RefinedCandidate,
    choose_candidate,
    mirror_descriptors,
    refine_start,
    symmetry_vertex_map,
    turned_self_map,
)
from .descriptors import check_landmarks, wave_kernel_signature, wks_energies
from .fmap_fit import DescriptorOperators, fit_functional_map
from .zoomout import farthest_point_samples, functional_map_from_p2p, zoomout

__all__ = [
    "MatchResult",
    "match",
    "match_result",
    "symmetry_map",
    "as_prepared_mesh",
    "matching_descriptors",
    "DEFAULT_WEIGHTS",
]

#: Dimensionless weights of the fit used by :func:`match` (see :mod:`.fmap_fit`).
DEFAULT_WEIGHTS = {"w_descr": 1.0, "w_lap": 1.0, "w_dcomm": 1.0, "w_orient": 1.0, "w_orth": 1.0}

#: Eigenpairs at which :func:`match` scores its candidate maps (:mod:`.candidates`).
K_SCORE = 30

#: Peak memory of the pipeline, an upper bound of what was measured (resident set on
#: 43k–173k vertices, tracemalloc on 10k–41k, k = 20–60): a fixed part (the blocks of
#: :data:`fvf.spectral.fmap_fit.BLOCK_BYTES` and the tiles of
#: :data:`fvf.spectral.zoomout.TILE_BYTES`), a part per vertex (mesh, operators, the
#: eigensolver's factorization, descriptors, a column of the orientation operators) and
#: a part per vertex and eigenpair (the bases, the embeddings searched). Nothing grows
#: faster than n k; checked against the available memory before any work.
PEAK_BYTES_FIXED = 256 * 2**20
PEAK_BYTES_PER_VERTEX = 6 * 2**10
PEAK_BYTES_PER_VERTEX_EIGENPAIR = 64


def peak_bytes(n: int, k: int) -> int:
    """Estimated peak memory (bytes) of :func:`match` or :func:`symmetry_map` with k
    eigenpairs on meshes of n vertices in all: :data:`PEAK_BYTES_FIXED` +
    n (:data:`PEAK_BYTES_PER_VERTEX` + k :data:`PEAK_BYTES_PER_VERTEX_EIGENPAIR`)."""
    return PEAK_BYTES_FIXED + n * (PEAK_BYTES_PER_VERTEX + k * PEAK_BYTES_PER_VERTEX_EIGENPAIR)


#: Size of the second, wider fit that :func:`match` refines as a further candidate when
#: the first two do not decide (:mod:`.candidates`): the K of pyFM's README pipeline. On
#: the remeshed FAUST bodies the fit at 15 lands in a whole-body flip on some pairs where
#: the fit at 30 does not (docs/correspondence.md, *Flips on near-symmetric shapes*).
K_WIDE = 30

#: The candidates of :func:`match` are refined by ZoomOut to about this size (the first
#: size of ZoomOut's steps from the start at or above it), scored and compared there;
#: only the chosen one is refined on to k. ZoomOut's work grows with the square of the
#: size, so a rejected candidate costs about a quarter of a refinement to k = 200. At
#: 60, FAUST_r 082 ← 083 ranks a whole-body rotation first (energies 2 % apart), as it
#: does not at 100 or 200 (docs/correspondence.md).
K_CHOICE = 100


@dataclass(frozen=True, eq=False)
class MatchResult:
    """Everything :func:`match_result` (or :func:`symmetry_map`) computed.

    A result is also its vertex map: ``np.asarray(result)``, ``len(result)``,
    ``result[i]``, ``result.shape`` and ``result.dtype`` are those of ``p2p_21``, so a
    result can be passed wherever the array :func:`match` returns is expected.

    Attributes
    ----------
    p2p_21 : int64 (n_2,)
        For each vertex of mesh 2 as passed, a vertex of mesh 1 as passed.
    C_12 : float64 (k, k)
        The refined functional map in ``basis_1``, ``basis_2`` (coefficients on mesh 1 ->
        on mesh 2; for a symmetry, the self-map's functional map).
    C_fit : float64 (k_fit, k_fit)
        The fitted map before ZoomOut.
    basis_1, basis_2 : SpectralBasis
        Bases of the prepared meshes at their own scale (the same object for a symmetry);
        use them with ``C_12``, e.g. ``fvf.map_consistent_field(result.basis_1,
        result.C_12)``.
    prepared_1, prepared_2 : PreparedMesh
        The clean meshes and the index maps to the input vertices.
    p2p_21_prepared : int64 (n_2',)
        The map between the prepared meshes.
    timings : dict
        Seconds per step.
    confidence : float or None
        How sure :func:`match` is of its choice among the fitted map, the fitted map
        composed with mesh 1's left-right symmetry and, when those two did not decide,
        the wider fit and the fit turned end for end (:mod:`fvf.spectral.candidates`):
        1 − E_chosen / E_runner-up in [0, 1], E the candidates' distortion × descriptor
        error × geodesic distortion × orientation energy, over candidates that are
        different maps. Near 0 the two best are about as good
        (an exactly symmetric pair); None when no choice was made
        (``check_symmetry=False``, :func:`symmetry_map`).
    alternatives : tuple of MapCandidate
        Every distinct candidate scored (name, energy, distortion, orientation
        agreement, chosen, descriptor error, geodesic distortion), lowest energy first;
        empty when no choice was made.
    """

    __repr__ = short_repr  # arrays by dtype and shape
    _repr_html_ = html_repr  # a table in Jupyter

    p2p_21: np.ndarray
    C_12: np.ndarray
    C_fit: np.ndarray
    basis_1: SpectralBasis
    basis_2: SpectralBasis
    prepared_1: PreparedMesh
    prepared_2: PreparedMesh
    p2p_21_prepared: np.ndarray
    timings: dict = field(default_factory=dict)
    confidence: float | None = None
    alternatives: tuple[MapCandidate, ...] = ()

    @property
    def C(self) -> np.ndarray:
        """Alias of ``C_12`` (natural for a self-map)."""
        return self.C_12

    @property
    def basis(self) -> SpectralBasis:
        """Alias of ``basis_1`` (natural for a self-map)."""
        return self.basis_1

    @property
    def p2p(self) -> np.ndarray:
        """Alias of ``p2p_21`` (natural for a self-map)."""
        return self.p2p_21

    # The vertex map as an array (numpy's array protocol and the sequence protocol).
    def __array__(self, dtype: npt.DTypeLike | None = None, copy: bool | None = None) -> np.ndarray:
        return np.array(self.p2p_21, dtype=dtype, copy=copy)  # numpy's copy semantics

    def __len__(self) -> int:
        return len(self.p2p_21)

    def __getitem__(self, index: Any) -> Any:
        return self.p2p_21[index]

    def __iter__(self) -> Iterator[Any]:
        return iter(self.p2p_21)

    @property
    def shape(self) -> tuple[int, ...]:
        """``p2p_21.shape``: (n_2,)."""
        return self.p2p_21.shape

    @property
    def dtype(self) -> np.dtype:
        """``p2p_21.dtype``: int64."""
        return self.p2p_21.dtype


# ---------------------------------------------------------------------------- inputs
def as_prepared_mesh(mesh: MeshLike, name: str = "mesh") -> PreparedMesh:
    """A TriMesh, a (vertices, faces) pair, a mesh file path or any mesh object
    :func:`fvf.as_mesh` converts, prepared for matching.

    Raises
    ------
    DisconnectedMeshError
        Several connected components besides specks of at most 1 % of the vertices.
    MeshError, MeshReadError
        Arrays or files that cannot be read or repaired.
    """
    return prepare_mesh(*input_arrays(mesh), name=name)  # one reading of every form


def _unit_area_basis(mesh: TriMesh, k: int, name: str) -> tuple[SpectralBasis, SpectralBasis]:
    """(basis of the unit-area copy, the same eigenpairs rescaled to ``mesh``)."""
    n = mesh.n_vertices
    if not 2 <= k < n:
        fix = (
            f"pass k <= {n - 1} (and 3 <= k_fit <= k), or a finer mesh"
            if n - 1 >= 3  # k_fit needs 3 eigenfunctions at least
            else "subdivide the mesh (a match needs 4 vertices at least)"
        )
        raise NotEnoughEigenpairsError(
            f"{name} has {n} vertices, too few for {k} eigenfunctions (need k < n). Fix: {fix}."
        )
    area = mesh.total_area
    unit = TriMesh(mesh.vertices / np.sqrt(area), mesh.faces)
    b_unit = SpectralBasis(unit, k)
    b_mesh = SpectralBasis.from_eigenpairs(
        mesh, b_unit.eigenvalues / area, b_unit.eigenvectors / np.sqrt(area)
    )
    return b_unit, b_mesh


def _landmark_pairs(
    landmarks: npt.ArrayLike | None, p1: PreparedMesh, p2: PreparedMesh
) -> tuple[np.ndarray, np.ndarray] | None:
    """(q, 2) input indices [vertex of mesh 1, vertex of mesh 2] -> prepared indices."""
    if landmarks is None:
        return None
    L = np.asarray(landmarks)
    if L.ndim != 2 or L.shape[1] != 2 or not np.issubdtype(L.dtype, np.integer):
        raise LandmarkError(
            "landmarks must be an integer array of shape (q, 2): row j holds a vertex of "
            f"mesh 1 and its corresponding vertex of mesh 2; got {L.dtype} {L.shape}."
        )
    if L.shape[0] == 0:
        return None
    l1 = check_landmarks(L[:, 0], p1.n_input, "landmarks[:, 0] (mesh 1)")
    l2 = check_landmarks(L[:, 1], p2.n_input, "landmarks[:, 1] (mesh 2)")
    m1, m2 = p1.input_to_mesh[l1], p2.input_to_mesh[l2]
    for m, name in ((m1, "mesh 1"), (m2, "mesh 2")):
        _, first, counts = np.unique(m, return_index=True, return_counts=True)
        if (counts > 1).any():
            raise LandmarkError(
                f"landmarks on {name} at rows {format_indices(np.sort(first[counts > 1]))} "
                "stand for the same vertex after repair; give landmarks on distinct vertices."
            )
    return m1, m2


def matching_descriptors(
    basis_1: SpectralBasis,
    basis_2: SpectralBasis,
    *,
    n_descriptors: int = 50,
    k_descr: int = 100,
    landmarks: tuple[np.ndarray, np.ndarray] | None = None,
    n_landmark_energies: int = 10,
) -> tuple[np.ndarray, np.ndarray]:
    """Corresponding WKS descriptors on two meshes, normalized, (n_1, p) and (n_2, p).

    Both use the same log-energies and σ (:func:`fvf.spectral.descriptors.wks_energies`
    of the mean of the two spectra, with twice as many energies as ``n_descriptors``,
    every other one kept) so that a column means the same on both shapes; the bases
    should be of unit-area meshes. With landmarks, ``n_landmark_energies`` landmark WKS
    columns per landmark are appended. Each column is divided by its A_V norm.

    Parameters
    ----------
    basis_1, basis_2 : SpectralBasis
        Same number of eigenpairs.
    n_descriptors : int
    k_descr : int
        Eigenpairs used (the first min(k_descr, k)).
    landmarks : (int64 (q,), int64 (q,)), optional
        Corresponding vertices of mesh 1 and mesh 2.
    n_landmark_energies : int

    Returns
    -------
    descr_1 : float64 (n_1, p)
    descr_2 : float64 (n_2, p)
    """
    if basis_1.k != basis_2.k:
        raise BasisSizeError(
            f"basis_1 has {basis_1.k} eigenpairs and basis_2 has {basis_2.k}; descriptors "
            "compare spectra term by term, so give both bases the same k."
        )
    k_d = min(int(k_descr), basis_1.k)
    basis_1, basis_2 = basis_1.truncate(k_d), basis_2.truncate(k_d)
    lam = 0.5 * (basis_1.eigenvalues + basis_2.eigenvalues)
    e, sigma = wks_energies(lam, 2 * int(n_descriptors))
    e = e[::2]
    d1 = [wave_kernel_signature(basis_1, e, sigma)]
    d2 = [wave_kernel_signature(basis_2, e, sigma)]
    if landmarks is not None:
        el, sl = wks_energies(lam, int(n_landmark_energies))
        d1.append(wave_kernel_signature(basis_1, el, sl, landmarks=landmarks[0]))
        d2.append(wave_kernel_signature(basis_2, el, sl, landmarks=landmarks[1]))
    out = []
    for basis, parts in ((basis_1, d1), (basis_2, d2)):
        D = np.hstack(parts)
        norm = np.sqrt(basis.mesh.vertex_areas @ (D * D))
        out.append(D / np.where(norm > 0, norm, 1.0))
    return out[0], out[1]


def _weights(weights: dict | None) -> dict:
    """:data:`DEFAULT_WEIGHTS` with the user's overrides; an unknown name is an error."""
    w = dict(DEFAULT_WEIGHTS)
    unknown = set(weights or {}) - set(w)
    if unknown:
        raise ParameterError(f"unknown weights {sorted(unknown)}; choose from {sorted(w)}")
    w.update(weights or {})
    return w


def _check_sizes(k: int, k_fit: int) -> tuple[int, int]:
    k, k_fit = int(k), int(k_fit)
    if not 3 <= k_fit <= k:
        raise ParameterError(f"need 3 <= k_fit <= k; got k_fit = {k_fit}, k = {k}")
    return k, k_fit


# ---------------------------------------------------------------------------- pipeline
def _correspond(
    p1: PreparedMesh,
    p2: PreparedMesh | None,
    *,
    k: int,
    k_fit: int,
    landmarks: tuple[np.ndarray, np.ndarray] | None,
    n_descriptors: int,
    orientation: str | None,
    weights: dict,
    zoomout_step: int,
    zoomout_samples: int | None,
    check_symmetry: bool = False,
    progress: Any = None,
) -> MatchResult:
    """The pipeline of the module docstring; p2 None means a self-map of p1."""
    report = make_progress(progress)
    n = p1.mesh.n_vertices + (0 if p2 is None else p2.mesh.n_vertices)
    check_memory(
        f"a correspondence on {n} vertices with k = {k}",
        peak_bytes(n, k),
        "a coarser mesh (decimate it; the map of a few tens of thousands of vertices "
        "carries to a finer mesh by nearest vertex) or a smaller k",
    )
    stages = 5 if check_symmetry and p2 is not None else 4
    timings = {}
    t = time.perf_counter()
    report("match", 0, stages)
    unit_1, basis_1 = _unit_area_basis(p1.mesh, k, "mesh_1")
    unit_2, basis_2 = (unit_1, basis_1) if p2 is None else _unit_area_basis(p2.mesh, k, "mesh_2")
    timings["bases"] = time.perf_counter() - t
    report("match", 1, stages)
    t = time.perf_counter()
    d1, d2 = matching_descriptors(unit_1, unit_2, n_descriptors=n_descriptors, landmarks=landmarks)
    timings["descriptors"] = time.perf_counter() - t
    report("match", 2, stages)
    t = time.perf_counter()
    ops_1 = DescriptorOperators.of(unit_1.truncate(k_fit), d1)  # shared by the small fits
    ops_2 = ops_1 if p2 is None else DescriptorOperators.of(unit_2.truncate(k_fit), d2)
    C_fit = fit_functional_map(
        unit_1,
        unit_2,
        d1,
        d2,
        k=k_fit,
        orientation=orientation,
        operators=(ops_1, ops_2),
        **weights,
    )
    timings["fit"] = time.perf_counter() - t
    report("match", 3, stages)
    n_min = min(unit_1.mesh.n_vertices, unit_2.mesh.n_vertices)
    samples = zoomout_samples if zoomout_samples and zoomout_samples < n_min else None
    if samples is not None and samples <= k:
        raise ParameterError(
            f"zoomout_samples = {samples} must exceed k = {k} (or be None for all vertices)"
        )
    confidence: float | None = None
    alternatives: tuple[MapCandidate, ...] = ()
    t = time.perf_counter()
    sample_idx = None
    if samples is not None:  # one farthest-point sampling per mesh, for every ZoomOut
        s1 = farthest_point_samples(unit_1.mesh.vertices, samples)
        s2 = s1 if p2 is None else farthest_point_samples(unit_2.mesh.vertices, samples)
        sample_idx = (s1, s2)
    if stages == 5:
        kw = {"k_fit": k_fit, "k_score": K_SCORE, "step": zoomout_step}
        own = None if sample_idx is None else sample_idx[0]
        sigma_1 = symmetry_vertex_map(unit_1, d1, weights, samples=own, operators=ops_1, **kw)
        C_sigma = functional_map_from_p2p(sigma_1, unit_1, unit_1, k_fit)
        starts = {"fit": C_fit, "fit∘symmetry": C_fit @ C_sigma}
        timings["symmetry"] = time.perf_counter() - t
        report("match", 4, stages)
        t = time.perf_counter()
        C, p2p, alternatives, confidence = _choose(
            starts,
            unit_1,
            unit_2,
            (d1, d2),
            weights,
            orientation,
            k,
            zoomout_step,
            sample_idx,
            sigma_1,
            (ops_1, ops_2),
        )
    else:
        C, p2p = zoomout(
            C_fit, unit_1, unit_2, k, step=zoomout_step, samples=sample_idx, progress=report
        )
    timings["zoomout"] = time.perf_counter() - t
    report("match", stages, stages)
    q2 = p1 if p2 is None else p2
    p2p_input = p1.mesh_to_input[p2p[q2.input_to_mesh]]
    return MatchResult(
        p2p_input, C, C_fit, basis_1, basis_2, p1, q2, p2p, timings, confidence, alternatives
    )


def _choose(
    starts: dict[str, np.ndarray],
    unit_1: SpectralBasis,
    unit_2: SpectralBasis,
    descriptors: tuple[np.ndarray, np.ndarray],
    weights: dict,
    orientation: str | None,
    k: int,
    step: int,
    samples: tuple[np.ndarray, np.ndarray] | None,
    sigma_1: np.ndarray,
    operators: tuple[DescriptorOperators, DescriptorOperators],
) -> tuple[np.ndarray, np.ndarray, tuple[MapCandidate, ...], float]:
    """Refine the starts to about :data:`K_CHOICE`, choose by eq. E of
    :mod:`.candidates`; when that choice is not decisive, refine the further starts of
    :func:`_further_starts` too and choose again. The chosen map is refined on to k.
    ``sigma_1`` is mesh 1's symmetry, int64 (n_1,); ``operators`` those of the
    descriptors on each mesh at the size of the fit."""
    sign = {"preserving": 1.0, "reversing": -1.0}.get(orientation or "", 0.0)
    probe = GeodesicProbe.on(
        unit_2.mesh, None if samples is None else samples[1][:GEODESIC_SAMPLES]
    )

    def refine(name: str, C0: np.ndarray) -> RefinedCandidate:
        return refine_start(
            name,
            C0,
            unit_1,
            unit_2,
            k_final=choice_size(C0.shape[1], k, step),
            k_score=K_SCORE,
            step=step,
            samples=samples,
            descriptors=descriptors,
            probe=probe,
        )

    refined = [refine(n, C0) for n, C0 in starts.items()]
    chosen = choose_candidate(refined, sign)
    C_fit = next(iter(starts.values()))
    if chosen[3] < DECISIVE_CONFIDENCE and C_fit.shape[1] < K_WIDE <= k:
        more = _further_starts(
            C_fit,
            unit_1,
            unit_2,
            descriptors,
            weights,
            orientation,
            step,
            samples,
            sigma_1,
            operators,
        )
        refined += [refine(n, C0) for n, C0 in more.items()]
        chosen = choose_candidate(refined, sign)
    C, p2p, candidates, confidence = chosen
    if C.shape[1] < k:  # on from the size of the choice, as one ZoomOut would have gone
        C, p2p = zoomout(C, unit_1, unit_2, k, step=step, samples=samples)
    return C, p2p, candidates, confidence


def choice_size(k_start: int, k: int, step: int) -> int:
    """The size a start of size ``k_start`` is refined to before the choice:
    :data:`K_CHOICE` rounded up to ZoomOut's sizes k_start + j ``step``, at most k, so
    that refining the chosen map on to k passes through the sizes of one ZoomOut."""
    j = max(0, -(-(K_CHOICE - k_start) // step))
    return min(k, k_start + j * step)


def _further_starts(
    C_fit: np.ndarray,
    unit_1: SpectralBasis,
    unit_2: SpectralBasis,
    descriptors: tuple[np.ndarray, np.ndarray],
    weights: dict,
    orientation: str | None,
    step: int,
    samples: tuple[np.ndarray, np.ndarray] | None,
    sigma_1: np.ndarray,
    operators: tuple[DescriptorOperators, DescriptorOperators],
) -> dict[str, np.ndarray]:
    """The starts of an undecided choice: the wide fit (``K_WIDE``), for an
    orientation-preserving match the fit turned end for end, and the mirror fit (the
    descriptors with both meshes' :func:`~.candidates.mirror_descriptors`)."""
    d1, d2 = descriptors
    ops_1, ops_2 = operators
    k_fit = C_fit.shape[1]
    kw = {"k_fit": k_fit, "k_score": K_SCORE, "step": step}
    s1, s2 = (None, None) if samples is None else samples
    starts = {
        "wide fit": fit_functional_map(
            unit_1, unit_2, d1, d2, k=K_WIDE, orientation=orientation, **weights
        )
    }
    if orientation == "preserving":  # the body turned end for end
        C_turn = turned_self_map(unit_1, d1, weights, samples=s1, operators=ops_1, **kw)
        starts["fit∘turn"] = C_fit @ C_turn
    sigma_2 = symmetry_vertex_map(unit_2, d2, weights, samples=s2, operators=ops_2, **kw)
    m1 = mirror_descriptors(unit_1, sigma_1)
    m2 = mirror_descriptors(unit_2, sigma_2)
    with_mirror = (  # only the mirror columns' operators are new
        ops_1.joined(DescriptorOperators.of(unit_1.truncate(k_fit), m1)),
        ops_2.joined(DescriptorOperators.of(unit_2.truncate(k_fit), m2)),
    )
    starts["mirror fit"] = fit_functional_map(
        unit_1,
        unit_2,
        np.hstack([d1, m1]),
        np.hstack([d2, m2]),
        k=k_fit,
        orientation=orientation,
        operators=with_mirror,
        **weights,
    )
    return starts


@overload
def match(
    mesh_1: MeshLike,
    mesh_2: MeshLike,
    *,
    k: int = ...,
    k_fit: int = ...,
    landmarks: npt.ArrayLike | None = ...,
    n_descriptors: int = ...,
    orientation: str | None = ...,
    weights: dict | None = ...,
    zoomout_step: int = ...,
    zoomout_samples: int | None = ...,
    check_symmetry: bool = ...,
    progress: bool | ProgressCallback | None = ...,
    full_output: Literal[False] | None = ...,
) -> np.ndarray: ...


@overload
def match(
    mesh_1: MeshLike,
    mesh_2: MeshLike,
    *,
    k: int = ...,
    k_fit: int = ...,
    landmarks: npt.ArrayLike | None = ...,
    n_descriptors: int = ...,
    orientation: str | None = ...,
    weights: dict | None = ...,
    zoomout_step: int = ...,
    zoomout_samples: int | None = ...,
    check_symmetry: bool = ...,
    progress: bool | ProgressCallback | None = ...,
    full_output: Literal[True],
) -> MatchResult: ...


@overload
def match(
    mesh_1: MeshLike,
    mesh_2: MeshLike,
    *,
    k: int = ...,
    k_fit: int = ...,
    landmarks: npt.ArrayLike | None = ...,
    n_descriptors: int = ...,
    orientation: str | None = ...,
    weights: dict | None = ...,
    zoomout_step: int = ...,
    zoomout_samples: int | None = ...,
    check_symmetry: bool = ...,
    progress: bool | ProgressCallback | None = ...,
    full_output: bool,
) -> np.ndarray | MatchResult: ...


def match(
    mesh_1: MeshLike,
    mesh_2: MeshLike,
    *,
    k: int = 200,
    k_fit: int = 15,
    landmarks: npt.ArrayLike | None = None,
    n_descriptors: int = 50,
    orientation: str | None = "preserving",
    weights: dict | None = None,
    zoomout_step: int = 5,
    zoomout_samples: int | None = 2000,
    check_symmetry: bool = True,
    progress: bool | ProgressCallback | None = None,
    full_output: bool | None = None,
) -> np.ndarray | MatchResult:
    """A vertex-to-vertex correspondence between two near-isometric shapes.

    The vertex map of :func:`match_result`, which returns everything computed (the
    functional maps, the bases, the prepared meshes, the timings).

    Parameters
    ----------
    mesh_1, mesh_2 : TriMesh, (vertices, faces), path or mesh object (:data:`fvf.MeshLike`)
        The shapes as you have them: non-manifold edges and vertices are repaired
        internally, alike for every form (``fvf.as_mesh(mesh, repair=True)`` is that
        repair), and the result indexes the vertices you passed.
    k : int
        Size of the final functional map (ZoomOut target, and eigenpairs computed).
    k_fit : int
        Size of the fitted functional map (see the module docstring).
    landmarks : array_like of int (q, 2), optional
        Row j: a vertex of mesh 1 and the corresponding vertex of mesh 2 (input indices).
    n_descriptors : int
        Number of WKS descriptors.
    orientation : {"preserving", "reversing", None}
        The orientation term: keep "preserving" for two shapes of the same orientation.
    weights : dict, optional
        Overrides of :data:`DEFAULT_WEIGHTS` (``w_descr``, ``w_lap``, ``w_dcomm``,
        ``w_orient``, ``w_orth``).
    zoomout_step : int
        Eigenpairs added per ZoomOut iteration.
    zoomout_samples : int or None
        ZoomOut iterates on this many farthest-point samples per mesh (all vertices when
        a mesh has fewer, or None); the final map is computed on all vertices.
    check_symmetry : bool
        Also try the fitted map composed with mesh 1's left-right symmetry, and, when
        the two do not decide, the fit at 30 eigenpairs, the fit turned end for end and
        the fit with the distances to the mirror image, and keep the candidate of
        lowest energy (:mod:`fvf.spectral.candidates`; the choice and its confidence
        are in :class:`MatchResult`). Costs a small fit, a ZoomOut to 30 eigenpairs and
        a second full ZoomOut, and, when undecided, mesh 2's symmetry, two fits and
        three more full ZoomOuts; guards near-symmetric shapes against flips and swapped
        limbs.
    progress : bool or callable, optional
        ``True``: a tqdm bar; a callable: called as ``progress("match", done, total)``
        after each step (bases, descriptors, fit, candidates, ZoomOut).
    full_output : bool, optional
        Deprecated: ``full_output=True`` returns :func:`match_result`'s
        :class:`MatchResult`, with a ``DeprecationWarning``; call :func:`match_result`.

    Returns
    -------
    p2p_21 : int64 (n_2,)
        For each vertex of mesh 2, a vertex of mesh 1 (the convention of
        :func:`fvf.functional_map`).

    Raises
    ------
    DisconnectedMeshError
        A mesh with several connected components of more than 1 % of its vertices each
        (several shapes); smaller ones (specks) are dropped with a
        :class:`~fvf.errors.SmallComponentWarning`.
    NotEnoughEigenpairsError
        A mesh with k or fewer vertices.
    LandmarkError
        Landmarks not of shape (q, 2), out of range or repeated.
    ParameterError
        k_fit outside [3, k], an unknown weight or option.
    ProblemSizeError
        Meshes whose estimated peak memory (:func:`peak_bytes`) exceeds the available
        memory; raised before any work.

    Examples
    --------
    >>> import numpy as np, fvf
    >>> mesh = fvf.jittered_sphere(2, 0.3, seed=2)
    >>> perm = np.random.default_rng(0).permutation(mesh.n_vertices)
    >>> p2p = fvf.match(mesh, (mesh.vertices[perm], np.argsort(perm)[mesh.faces]), k=30)
    >>> float(np.mean(p2p == perm)) > 0.9
    True
    """
    if full_output is not None:
        warnings.warn(
            "fvf.match(..., full_output=...) is deprecated: call fvf.match_result(...) for "
            "the MatchResult, fvf.match(...) for the vertex map",
            DeprecationWarning,
            stacklevel=2,
        )
    result = match_result(
        mesh_1,
        mesh_2,
        k=k,
        k_fit=k_fit,
        landmarks=landmarks,
        n_descriptors=n_descriptors,
        orientation=orientation,
        weights=weights,
        zoomout_step=zoomout_step,
        zoomout_samples=zoomout_samples,
        check_symmetry=check_symmetry,
        progress=progress,
    )
    return result if full_output else result.p2p_21


def match_result(
    mesh_1: MeshLike,
    mesh_2: MeshLike,
    *,
    k: int = 200,
    k_fit: int = 15,
    landmarks: npt.ArrayLike | None = None,
    n_descriptors: int = 50,
    orientation: str | None = "preserving",
    weights: dict | None = None,
    zoomout_step: int = 5,
    zoomout_samples: int | None = 2000,
    check_symmetry: bool = True,
    progress: bool | ProgressCallback | None = None,
) -> MatchResult:
    """Everything :func:`match` computes: the vertex map, functional maps, bases, timings.

    The same pipeline and arguments as :func:`match`; the :class:`MatchResult` is also
    its vertex map (``np.asarray(result)`` equals ``result.p2p_21``).

    Parameters
    ----------
    mesh_1, mesh_2 : TriMesh, (vertices, faces), path or mesh object (:data:`fvf.MeshLike`)
        The shapes as you have them: non-manifold edges and vertices are repaired
        internally, alike for every form (``fvf.as_mesh(mesh, repair=True)`` is that
        repair), and the result indexes the vertices you passed.
    k : int
        Size of the final functional map (ZoomOut target, and eigenpairs computed).
    k_fit : int
        Size of the fitted functional map (see the module docstring).
    landmarks : array_like of int (q, 2), optional
        Row j: a vertex of mesh 1 and the corresponding vertex of mesh 2 (input indices).
    n_descriptors : int
        Number of WKS descriptors.
    orientation : {"preserving", "reversing", None}
        The orientation term: keep "preserving" for two shapes of the same orientation.
    weights : dict, optional
        Overrides of :data:`DEFAULT_WEIGHTS` (``w_descr``, ``w_lap``, ``w_dcomm``,
        ``w_orient``, ``w_orth``).
    zoomout_step : int
        Eigenpairs added per ZoomOut iteration.
    zoomout_samples : int or None
        ZoomOut iterates on this many farthest-point samples per mesh (all vertices when
        a mesh has fewer, or None); the final map is computed on all vertices.
    check_symmetry : bool
        Also try the fitted map composed with mesh 1's left-right symmetry, and, when
        the two do not decide, the fit at 30 eigenpairs, the fit turned end for end and
        the fit with the distances to the mirror image, and keep the candidate of
        lowest energy (:mod:`fvf.spectral.candidates`; the choice and its confidence
        are in :class:`MatchResult`). Costs a small fit, a ZoomOut to 30 eigenpairs and
        a second full ZoomOut, and, when undecided, mesh 2's symmetry, two fits and
        three more full ZoomOuts; guards near-symmetric shapes against flips and swapped
        limbs.
    progress : bool or callable, optional
        ``True``: a tqdm bar; a callable: called as ``progress("match", done, total)``
        after each step (bases, descriptors, fit, candidates, ZoomOut).

    Returns
    -------
    MatchResult
        ``p2p_21`` int64 (n_2,): for each vertex of mesh 2, a vertex of mesh 1;
        ``C_12`` (k, k) in ``basis_1``, ``basis_2``; ``C_fit`` (k_fit, k_fit); the
        prepared meshes and ``timings``.

    Raises
    ------
    DisconnectedMeshError
        A mesh with several connected components of more than 1 % of its vertices each
        (several shapes); smaller ones (specks) are dropped with a
        :class:`~fvf.errors.SmallComponentWarning`.
    NotEnoughEigenpairsError
        A mesh with k or fewer vertices.
    LandmarkError
        Landmarks not of shape (q, 2), out of range or repeated.
    ParameterError
        k_fit outside [3, k], an unknown weight or option.
    ProblemSizeError
        Meshes whose estimated peak memory (:func:`peak_bytes`) exceeds the available
        memory; raised before any work.

    Examples
    --------
    >>> import numpy as np, fvf
    >>> mesh = fvf.jittered_sphere(2, 0.3, seed=2)
    >>> result = fvf.match_result(mesh, mesh, k=30)
    >>> result.C_12.shape, np.asarray(result).shape == (mesh.n_vertices,)
    ((30, 30), True)
    """
    k, k_fit = _check_sizes(k, k_fit)
    w = _weights(weights)
    p1 = as_prepared_mesh(mesh_1, "mesh_1")
    p2 = as_prepared_mesh(mesh_2, "mesh_2")
    lm = _landmark_pairs(landmarks, p1, p2)
    return _correspond(
        p1,
        p2,
        k=k,
        k_fit=k_fit,
        landmarks=lm,
        n_descriptors=n_descriptors,
        orientation=orientation,
        weights=w,
        zoomout_step=zoomout_step,
        zoomout_samples=zoomout_samples,
        check_symmetry=check_symmetry,
        progress=progress,
    )


def symmetry_map(
    mesh: MeshLike,
    *,
    k: int = 100,
    k_fit: int = 15,
    n_descriptors: int = 50,
    weights: dict | None = None,
    zoomout_step: int = 5,
    zoomout_samples: int | None = 2000,
    progress: bool | ProgressCallback | None = None,
) -> MatchResult:
    """The orientation-reversing intrinsic self-map (left-right symmetry) of a shape.

    The same pipeline as :func:`match` from the mesh to itself, with the orientation term
    reversed: C P_j = −P_j C for the reduced operators P_j of D_{J grad f_j}, which the
    identity violates as much as possible, so the fit lands on the reflection.

    Parameters
    ----------
    mesh : TriMesh, (vertices, faces), path or mesh object (:data:`fvf.MeshLike`)
    k, k_fit, n_descriptors, weights, zoomout_step, zoomout_samples, progress
        As for :func:`match` (progress reports the steps as ``"match"``, and the final
        search of each vertex's image, the longest step on a large mesh, as
        ``progress("nearest", done, n)``).

    Returns
    -------
    MatchResult
        ``result.p2p`` int64 (n,): the image of each input vertex (also
        ``np.asarray(result)``); ``result.C`` (k, k)
        and ``result.basis`` the functional map of the symmetry in the prepared mesh's
        basis, ready for ``fvf.map_consistent_field(result.basis, result.C)``.

    Raises
    ------
    As for :func:`match`.
    """
    k, k_fit = _check_sizes(k, k_fit)
    w = _weights(weights)
    p = as_prepared_mesh(mesh, "mesh")
    return _correspond(
        p,
        None,
        k=k,
        k_fit=k_fit,
        landmarks=None,
        n_descriptors=n_descriptors,
        orientation="reversing",
        weights=w,
        zoomout_step=zoomout_step,
        zoomout_samples=zoomout_samples,
        progress=progress,
    )
