"""Choosing among candidate maps: the fitted map, its mirror, a wider fit, the turned fit,
the mirror fit.

On a near-symmetric shape (a body, an animal) the fitted functional map can land in the
basin of the map composed with the left-right symmetry σ of the source (limbs swapped),
or in that of a whole-body rotation: left and right swapped and the front turned to the
back, so that the map still preserves orientation. The descriptors cannot tell the truth
from its mirror: they are intrinsic, and σ preserves them. How far each refined
candidate is from an isometry, from carrying the descriptors over and from the requested
orientation does tell them apart, which is how BCICP (Ren et al. 2018) and the discrete
solvers of Ren et al. 2021 pick among symmetric candidates, and Smooth Shells
(Eisenberger et al. 2020) among several initial alignments.

So :func:`fvf.match` builds the candidates

    C_fit            and          C_fit C_σ          (k_fit × k_fit)

with C_σ the functional map of the source's orientation-reversing self-map (the fit of
:func:`fvf.symmetry_map`, ZoomOut to ``k_score``), and, when the choice between those two
is not decisive (:data:`DECISIVE_CONFIDENCE`), the fit at a wider size (``K_WIDE`` of
:mod:`.correspondence`), for an orientation-preserving match C_fit C_τ with C_τ the
source's turned self-map (:func:`turned_self_map`: the body turned end for end), and the
mirror fit: the fit with each shape's distance to its own mirror image appended to the
descriptors (:func:`mirror_descriptors`; σ of both shapes). That distance is about 0 on
the plane of symmetry and large on paired limbs, so the mirror fit does not send a tail
to a leg, which the kernel signatures alone can when a tail is shaped like a lower leg;
it is not in the first pair of candidates because it weakens the orientation term's
share of the fit, and a decisive first choice ends the search. Each is
refined by ZoomOut to about 100 eigenpairs (``K_CHOICE`` of :mod:`.correspondence`; only
the chosen one goes on to the final size k) and converted to a vertex map π, and the
functional map C_π = Φ_2ᵀ[A_V2] Π Φ_1 of that vertex map (unit-area meshes, ``k_score``
eigenpairs) is scored by its distortion

    δ(C_π) = Σ_ij M_ij (C_π)_ij² / k  +  ‖C_πᵀ C_π − I‖² / k             (eq. D)

with M the resolvent mask of :func:`fvf.spectral.fmap_fit.laplacian_mask`: the first
term vanishes for an isometry (it commutes with the Laplacians), the second for a
bijective, area-preserving map. The descriptor error of π is

    ε(π) = Σ_y a_2(y) ‖F_1(π(y)) − F_2(y)‖² / p                          (eq. P)

with F_1, F_2 the p corresponding descriptors of the fit (each column of unit A_V norm)
and a_2 the vertex areas of mesh 2: 0 when π carries every descriptor over. The geodesic
distortion of π is

    γ(π) = Σ_ij |d_1(π(x_i), π(x_j)) − d_2(x_i, x_j)| / s²                (eq. G)

over s samples x_i of mesh 2 (:class:`GeodesicProbe`), d the ``"unfolded"`` geodesic
distances of :func:`fvf.geodesic_distances` on the unit-area meshes: 0 for an isometry.
The energy of a candidate is

    E = (δ + δ_0) (ε + δ_0) (γ + δ_0) (1 + (ρ − 1)(1 − s a) / 2)        (eq. E)

with a ∈ [−1, 1] its :func:`fvf.orientation_agreement` and s the requested sign
(+1 ``"preserving"``, −1 ``"reversing"``, 0 for None): a candidate of the wrong
orientation must be ρ = :data:`ORIENTATION_FACTOR` times better in δ ε γ to win. It
does against a mirror image, where the reflection is exact (δ = ε = 0) and the
orientation-preserving alternative is not; between two exact candidates (an exactly
symmetric shape) the floor δ_0 makes the orientation decide. Distortion alone would not
do: a near-symmetric body's reversed map can be less distorted than the truth of a
non-isometric pose change. The product needs no weight between its factors (each enters
by its ratio between candidates): on the remeshed FAUST bodies a whole-body rotation can
be less distorted than the truth at 30 eigenpairs, but it carries the descriptors over
worse; on animals of different proportions a body turned end for end can carry the
descriptors over and commute with the Laplacians about as well as the truth, but it
changes the geodesic distances more (docs/correspondence.md). Two candidates that send a
majority of the vertices to the same images are one map; the lowest energy wins, and
1 − E_winner / E_runner-up over the distinct maps is reported as the confidence.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..mesh.trimesh import TriMesh
from ..numerics.summary import html_repr, short_repr
from .basis import SpectralBasis
from .descriptors import mirror_distance
from .evaluation import geodesic_distances, orientation_agreement
from .fmap_fit import DescriptorOperators, fit_functional_map, laplacian_mask
from .zoomout import farthest_point_samples, functional_map_from_p2p, zoomout

__all__ = [
    "MapCandidate",
    "map_distortion",
    "score_candidates",
    "refine_start",
    "choose_candidate",
    "candidate_energy",
    "descriptor_error",
    "geodesic_distortion",
    "GeodesicProbe",
    "turned_self_map",
    "symmetry_vertex_map",
    "mirror_descriptors",
    "RefinedCandidate",
    "ORIENTATION_FACTOR",
    "DISTORTION_FLOOR",
    "DECISIVE_CONFIDENCE",
]

#: ρ of eq. E: a candidate of the opposite orientation must be this many times less
#: distorted to win. Measured on the FAUST frame (δ at 30 eigenpairs after ZoomOut to
#: 200): against its mirror image the exact reflection has δ = 0 and the orientation-
#: preserving alternative 0.0006; against a smoothly displaced copy the truth has 0.018
#: and the orientation-reversing alternative 0.012, so distortion alone would flip it.
ORIENTATION_FACTOR = 4.0

#: δ_0 of eq. E: distortions this small count as exact (a tie that orientation breaks).
DISTORTION_FLOOR = 1e-9

#: A choice is decisive when the runner-up's energy is at least ρ² times the winner's:
#: the orientation factor accounts for at most ρ of it, so the distortion alone must
#: separate the two by another factor ρ (an exact or near-exact map against its mirror).
#: Below this, :func:`fvf.match` also refines a wider fit.
DECISIVE_CONFIDENCE = 1.0 - 1.0 / ORIENTATION_FACTOR**2

#: Farthest-point samples of mesh 2 whose pairwise geodesic distances γ (eq. G) compares.
GEODESIC_SAMPLES = 50

#: Weight of the pair (φ_1, −φ_1) appended to the descriptors of the turned self-map's fit
#: (:func:`turned_self_map`), in copies of one column: 25 against the 50 wave kernel
#: signatures of :func:`fvf.match` (the column is scaled by its square root, which weighs
#: it as that many copies in every term of the fit).
TURN_WEIGHT = 25

#: Weight of each mirror-distance column (:func:`mirror_descriptors`) in the mirror fit,
#: in copies of one column: its four columns weigh as 12 of the 50 wave kernel
#: signatures.
MIRROR_WEIGHT = 3.0

#: Scales s of the columns exp(−(m / s)²) of :func:`mirror_descriptors`, in units of
#: the mean mirror distance.
MIRROR_SCALES = (0.25, 0.5, 1.0)

#: Eigenpairs of the biharmonic distance in :func:`mirror_descriptors`.
MIRROR_EIGENPAIRS = 30


@dataclass(frozen=True)
class MapCandidate:
    """One candidate map of :func:`fvf.match_result`, with its score.

    Attributes
    ----------
    name : str
        ``"fit"`` (the fitted map), ``"fit∘symmetry"`` (composed with the source's
        self-symmetry), ``"wide fit"`` (the fit at the wider size), ``"fit∘turn"``
        (composed with the source's turned self-map, :func:`turned_self_map`) or
        ``"mirror fit"`` (the fit with :func:`mirror_descriptors`).
    energy : float
        E of eq. E, the number compared (lower wins).
    distortion : float
        δ of eq. D at ``k_score`` eigenpairs.
    orientation : float
        :func:`fvf.orientation_agreement` of the candidate's vertex map, in [−1, 1].
    chosen : bool
        Whether this candidate is the one returned.
    descriptor_error : float
        ε of eq. P (0 when no descriptors were given).
    geodesic_distortion : float
        γ of eq. G (0 when not measured).
    """

    name: str
    energy: float
    distortion: float
    orientation: float
    chosen: bool = False
    descriptor_error: float = 0.0
    geodesic_distortion: float = 0.0


@dataclass(frozen=True, eq=False)
class RefinedCandidate:
    """A start after ZoomOut, before the choice (:func:`refine_start`).

    Attributes
    ----------
    name : str
    C_12 : float64 (k, k)
        The refined functional map.
    p2p_21 : int64 (n_2,)
        Its vertex map.
    distortion : float
        δ of eq. D.
    orientation : float
        :func:`fvf.orientation_agreement` of ``p2p_21``.
    descriptor_error : float
        ε of eq. P (0 when no descriptors were given).
    geodesic_distortion : float
        γ of eq. G (0 when not measured).
    """

    __repr__ = short_repr  # arrays by dtype and shape
    _repr_html_ = html_repr  # a table in Jupyter

    name: str
    C_12: np.ndarray
    p2p_21: np.ndarray
    distortion: float
    orientation: float
    descriptor_error: float = 0.0
    geodesic_distortion: float = 0.0


def map_distortion(
    p2p_21: np.ndarray, basis_1: SpectralBasis, basis_2: SpectralBasis, k: int
) -> float:
    """δ of eq. D for the vertex map p2p_21 (mesh 2 -> mesh 1), with k eigenpairs.

    Parameters
    ----------
    p2p_21 : int64 (n_2,)
    basis_1, basis_2 : SpectralBasis
        Bases of unit-area meshes (δ is then scale-free), at least k eigenpairs each.
    k : int

    Returns
    -------
    float >= 0; 0 for an exact isometry.
    """
    C = functional_map_from_p2p(p2p_21, basis_1, basis_2, k)
    mask = laplacian_mask(basis_1.eigenvalues[:k], basis_2.eigenvalues[:k])
    G = C.T @ C - np.eye(k)
    return float(((mask * C * C).sum() + (G * G).sum()) / k)


def refine_start(
    name: str,
    C0: np.ndarray,
    basis_1: SpectralBasis,
    basis_2: SpectralBasis,
    *,
    k_final: int,
    k_score: int,
    step: int,
    samples: int | tuple[np.ndarray, np.ndarray] | None,
    descriptors: tuple[np.ndarray, np.ndarray] | None = None,
    probe: GeodesicProbe | None = None,
) -> RefinedCandidate:
    """ZoomOut one start to ``k_final`` and measure δ (eq. D), a, ε (eq. P) and γ
    (eq. G) of its vertex map.

    Parameters
    ----------
    name : str
    C0 : float64 (k_fit, k_fit)
        The start C_12.
    basis_1, basis_2 : SpectralBasis
        Unit-area bases with at least ``k_final`` eigenpairs.
    k_final, k_score, step, samples, descriptors, probe
        As for :func:`score_candidates`.

    Returns
    -------
    RefinedCandidate
    """
    C, p2p = zoomout(C0, basis_1, basis_2, k_final, step=step, samples=samples)
    delta = map_distortion(p2p, basis_1, basis_2, min(k_score, k_final))
    a = orientation_agreement(basis_1.mesh, basis_2.mesh, p2p)
    eps = 0.0 if descriptors is None else descriptor_error(p2p, basis_2, *descriptors)
    gamma = 0.0 if probe is None else geodesic_distortion(p2p, basis_1.mesh, probe)
    return RefinedCandidate(name, C, p2p, float(delta), float(a), eps, gamma)


@dataclass(frozen=True, eq=False)
class GeodesicProbe:
    """Samples of mesh 2 and their pairwise geodesic distances, for γ (eq. G).

    Attributes
    ----------
    sources : int64 (s,)
        Vertices x_i of mesh 2.
    distances : float64 (s, s)
        d_2(x_i, x_j) (``"unfolded"`` geodesics of :func:`fvf.geodesic_distances`).
    """

    __repr__ = short_repr
    _repr_html_ = html_repr

    sources: np.ndarray
    distances: np.ndarray

    @classmethod
    def on(cls, mesh_2: TriMesh, sources: np.ndarray | None = None) -> GeodesicProbe:
        """The probe of mesh 2 at ``sources`` (default: :data:`GEODESIC_SAMPLES`
        farthest-point samples)."""
        if sources is None:
            sources = farthest_point_samples(mesh_2.vertices, GEODESIC_SAMPLES)
        s = np.asarray(sources, dtype=np.int64)
        return cls(s, geodesic_distances(mesh_2, s)[:, s])


def geodesic_distortion(p2p_21: np.ndarray, mesh_1: TriMesh, probe: GeodesicProbe) -> float:
    """γ of eq. G: the mean |d_1(π x_i, π x_j) − d_2(x_i, x_j)| over the probe's samples.

    Parameters
    ----------
    p2p_21 : int64 (n_2,)
    mesh_1 : TriMesh
        Mesh 1, of the same scale as the probe's mesh 2 (unit area: γ is then scale-free).
    probe : GeodesicProbe

    Returns
    -------
    float >= 0; 0 for an isometry (up to the geodesics' own error).
    """
    img = np.asarray(p2p_21)[probe.sources]
    d1 = geodesic_distances(mesh_1, img)[:, img]
    return float(np.abs(d1 - probe.distances).mean())


def turned_self_map(
    basis: SpectralBasis,
    descriptors: np.ndarray,
    weights: dict,
    *,
    k_fit: int,
    k_score: int,
    step: int,
    samples: np.ndarray | None,
    operators: DescriptorOperators | None = None,
) -> np.ndarray:
    """C_τ: the orientation-preserving self-map of mesh 1 that turns φ_1 to −φ_1.

    The fit of :func:`fvf.fit_functional_map` from the mesh to itself, orientation
    ``"preserving"``, with the descriptor pair (φ_1, −φ_1) appended at the weight
    :data:`TURN_WEIGHT` (φ_1 the first non-constant eigenfunction, of unit A_V norm), so
    that the identity no longer fits: on an elongated body φ_1 runs from one end to the
    other, and the map found is the body turned end for end (front limbs on back limbs,
    left on right). ZoomOut to ``k_score`` on ``samples``, then its functional map.

    Parameters
    ----------
    basis : SpectralBasis
        Unit-area basis of mesh 1 with at least ``max(k_fit, k_score)`` eigenpairs.
    descriptors : float64 (n, p)
        The fit's descriptors of mesh 1.
    weights : dict
        The fit's weights (as for :func:`fvf.fit_functional_map`).
    k_fit, k_score, step : int
    samples : int64 (s,), optional
        Vertex samples of mesh 1 for ZoomOut (None: every vertex).
    operators : DescriptorOperators, optional
        The operators of ``descriptors`` at a size of at least k_fit (default: computed).

    Returns
    -------
    float64 (k_fit, k_fit)
    """
    phi = basis.eigenvectors[:, 1]
    phi = phi / np.sqrt(basis.mesh.vertex_areas @ (phi * phi))
    extra = np.sqrt(TURN_WEIGHT) * phi[:, None]  # as TURN_WEIGHT copies in every term
    d_1, d_2 = np.hstack([descriptors, extra]), np.hstack([descriptors, -extra])
    pair = None
    if operators is not None:  # only the appended column's operators are new
        extra_ops = DescriptorOperators.of(basis.truncate(k_fit), extra)
        pair = (operators.joined(extra_ops), operators.joined(extra_ops.scaled(-1.0)))
    tau = _self_map(basis, d_1, d_2, "preserving", weights, k_fit, k_score, step, samples, pair)
    return functional_map_from_p2p(tau, basis, basis, k_fit)


def symmetry_vertex_map(
    basis: SpectralBasis,
    descriptors: np.ndarray,
    weights: dict,
    *,
    k_fit: int,
    k_score: int,
    step: int,
    samples: np.ndarray | None,
    operators: DescriptorOperators | None = None,
) -> np.ndarray:
    """σ: the orientation-reversing self-map of the mesh (the fit of
    :func:`fvf.symmetry_map`, ZoomOut to ``k_score``), as a vertex map.

    Parameters as for :func:`turned_self_map`.

    Returns
    -------
    int64 (n,)
        For each vertex, its mirror image.
    """
    d = descriptors
    pair = None if operators is None else (operators, operators)
    return _self_map(basis, d, d, "reversing", weights, k_fit, k_score, step, samples, pair)


def mirror_descriptors(basis: SpectralBasis, symmetry: np.ndarray) -> np.ndarray:
    """Descriptor columns of the distance to the mirror image, for the mirror fit.

    m = :func:`fvf.spectral.descriptors.mirror_distance` divided by its area-weighted
    mean, then the columns m and exp(−(m / s)²) for s in :data:`MIRROR_SCALES` (near 0
    on the plane of symmetry, 1 on it), each of unit A_V norm and scaled by
    √:data:`MIRROR_WEIGHT`.

    Parameters
    ----------
    basis : SpectralBasis
        Unit-area basis with at least :data:`MIRROR_EIGENPAIRS` eigenpairs.
    symmetry : int64 (n,)
        σ of :func:`symmetry_vertex_map`.

    Returns
    -------
    float64 (n, 1 + len(MIRROR_SCALES))
    """
    a = basis.mesh.vertex_areas
    m = mirror_distance(basis, symmetry, MIRROR_EIGENPAIRS)
    m = m / max(float(a @ m), 1e-300)
    D = np.stack([m] + [np.exp(-((m / s) ** 2)) for s in MIRROR_SCALES], axis=1)
    norm = np.sqrt(a @ (D * D))
    return np.sqrt(MIRROR_WEIGHT) * D / np.where(norm > 0, norm, 1.0)


def _self_map(
    basis: SpectralBasis,
    d_1: np.ndarray,
    d_2: np.ndarray,
    orientation: str,
    weights: dict,
    k_fit: int,
    k_score: int,
    step: int,
    samples: np.ndarray | None,
    operators: tuple[DescriptorOperators, DescriptorOperators] | None = None,
) -> np.ndarray:
    """Fit a (k_fit, k_fit) self-map from descriptors d_1 to d_2 (their operators given
    or computed), ZoomOut to ``k_score``, and return its vertex map, int64 (n,)."""
    C = fit_functional_map(
        basis, basis, d_1, d_2, k=k_fit, orientation=orientation, operators=operators, **weights
    )
    k_z = max(min(k_score, basis.k), k_fit)
    pair = None if samples is None else (samples, samples)
    _, p2p = zoomout(C, basis, basis, k_z, step=step, samples=pair)
    return p2p


def descriptor_error(
    p2p_21: np.ndarray, basis_2: SpectralBasis, descr_1: np.ndarray, descr_2: np.ndarray
) -> float:
    """ε of eq. P: how far the vertex map is from carrying the descriptors over.

    Parameters
    ----------
    p2p_21 : int64 (n_2,)
    basis_2 : SpectralBasis
        Basis of the unit-area mesh 2 (its vertex areas weigh the sum).
    descr_1 : float64 (n_1, p)
    descr_2 : float64 (n_2, p)
        Corresponding descriptor columns, each of unit A_V norm on its mesh.

    Returns
    -------
    float >= 0; 0 when every descriptor is carried over exactly.
    """
    diff = descr_1[p2p_21] - descr_2
    return float(basis_2.mesh.vertex_areas @ (diff * diff).sum(axis=1)) / descr_2.shape[1]


def candidate_energy(
    delta: float, orientation: float, sign: float, eps: float = 0.0, gamma: float = 0.0
) -> float:
    """E of eq. E: (δ + δ_0)(ε + δ_0)(γ + δ_0)(1 + (ρ − 1)(1 − s a)/2)."""
    factor = 1.0 + (ORIENTATION_FACTOR - 1.0) * (1.0 - sign * orientation) / 2.0
    floor = DISTORTION_FLOOR
    return (delta + floor) * (eps + floor) * (gamma + floor) * factor


def choose_candidate(
    refined: list[RefinedCandidate], sign: float
) -> tuple[np.ndarray, np.ndarray, tuple[MapCandidate, ...], float]:
    """The refined candidate of lowest energy (eq. E).

    Two candidates that send a majority of the vertices of mesh 2 to the same vertices
    are one map (two starts refined into one basin); only the lower-energy one is kept,
    so the list and the confidence compare different maps.

    Parameters
    ----------
    refined : list of RefinedCandidate
        In order of preference on equal energies.
    sign : float
        s: +1, −1 or 0.

    Returns
    -------
    C, p2p_21, candidates, confidence
        As for :func:`score_candidates`.
    """
    energies = [
        candidate_energy(
            r.distortion, r.orientation, sign, r.descriptor_error, r.geodesic_distortion
        )
        for r in refined
    ]
    order = sorted(range(len(refined)), key=lambda i: energies[i])  # stable on ties
    kept: list[int] = []
    for i in order:
        if all(np.mean(refined[i].p2p_21 == refined[j].p2p_21) <= 0.5 for j in kept):
            kept.append(i)
    best = kept[0]
    confidence = 1.0 if len(kept) == 1 else 1.0 - energies[best] / energies[kept[1]]
    cands = tuple(
        MapCandidate(
            refined[i].name,
            energies[i],
            refined[i].distortion,
            refined[i].orientation,
            i == best,
            refined[i].descriptor_error,
            refined[i].geodesic_distortion,
        )
        for i in kept
    )
    win = refined[best]
    return win.C_12, win.p2p_21, cands, float(min(max(confidence, 0.0), 1.0))


def score_candidates(
    starts: dict[str, np.ndarray],
    basis_1: SpectralBasis,
    basis_2: SpectralBasis,
    *,
    k_final: int,
    k_score: int,
    step: int,
    samples: int | tuple[np.ndarray, np.ndarray] | None,
    sign: float,
    descriptors: tuple[np.ndarray, np.ndarray] | None = None,
    probe: GeodesicProbe | None = None,
) -> tuple[np.ndarray, np.ndarray, tuple[MapCandidate, ...], float]:
    """Refine each start by ZoomOut to ``k_final``, score it (eq. E), keep the lowest.

    Parameters
    ----------
    starts : dict name -> float64 (k_fit, k_fit)
        The candidate functional maps C_12 (any sizes up to ``k_final``).
    basis_1, basis_2 : SpectralBasis
        Unit-area bases with at least ``k_final`` eigenpairs.
    k_final : int
        ZoomOut's target.
    k_score : int
        Eigenpairs of the distortion δ (at most ``k_final``).
    step, samples
        ZoomOut's step and vertex samples (see :func:`fvf.zoomout`).
    sign : float
        s: +1, −1 or 0.
    descriptors : (float64 (n_1, p), float64 (n_2, p)), optional
        Corresponding unit-norm descriptors for ε (eq. P); without them ε is left out.
    probe : GeodesicProbe, optional
        Samples of mesh 2 for γ (eq. G); without it γ is left out.

    Returns
    -------
    C : float64 (k_final, k_final)
        The winner's refined functional map.
    p2p_21 : int64 (n_2,)
        Its vertex map.
    candidates : tuple of MapCandidate
        Every distinct candidate, lowest energy first, the winner marked.
    confidence : float
        1 − E_winner / E_runner-up in [0, 1] (1 with a single candidate).
    """
    refined = [
        refine_start(
            name,
            C0,
            basis_1,
            basis_2,
            k_final=k_final,
            k_score=k_score,
            step=step,
            samples=samples,
            descriptors=descriptors,
            probe=probe,
        )
        for name, C0 in starts.items()
    ]
    return choose_candidate(refined, sign)
