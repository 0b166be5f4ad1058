"""Fitting a functional map from descriptors: the energy and its exact minimizer.

The unknown is C_12 (k_2, k_1), taking coefficients on mesh 1 to coefficients on mesh 2
(the convention of :func:`fvf.functional_map`). With descriptors f_j on mesh 1 and g_j on
mesh 2 (corresponding columns), reduced to the bases as A = Φ_1ᵀ[A_V1] F (k_1, p) and
B = Φ_2ᵀ[A_V2] G (k_2, p), the energy is a sum of five terms, the first four quadratic

    E(C) = w_d ‖C A − B‖² / τ_d                                  descriptor preservation
         + w_l Σ_ij M_ij C_ij² / τ_l                              Laplacian commutativity
         + w_c Σ_j ‖C X_j − Y_j C‖² / τ_c                         descriptor commutativity
         + w_o Σ_j ‖C P_j − s Q_j C‖² / τ_o                       orientation
         + w_r ‖CᵀC − I‖² / 4                                     area preservation

(Ovsjanikov et al. 2012; Nogneng & Ovsjanikov 2017; Ren et al. 2018) with

- M_ij = (λ_1j − λ_2i)² (``laplacian="squared"``) or the bounded resolvent mask of Ren et
  al. 2019 (``laplacian="resolvent"``), both zero exactly where C may map eigenspaces of
  equal eigenvalue to each other;
- X_j = Φ_1ᵀ A_V1 diag(f_j) Φ_1, Y_j = Φ_2ᵀ A_V2 diag(g_j) Φ_2: the multiplication operators of the
  descriptors, which a pointwise map makes commute with C;
- P_j = Φ_1ᵀ[A_V1] D^V_{J grad f_j} Φ_1 and Q_j likewise on mesh 2: the functional vector
  fields of the rotated descriptor gradients (the chapter's D_v, reduced by
  :meth:`SpectralBasis.reduced_D`). D_{J∇f} g = ⟨J∇f, ∇g⟩ = ⟨∇f × ∇g, N⟩ changes sign
  with the orientation, so an orientation-preserving map makes C P_j = Q_j C
  (s = +1) and an orientation-reversing one C P_j = −Q_j C (s = −1);
- τ the mean diagonal of each term's Hessian, so the weights w are dimensionless (the
  last term's Hessian at an orthonormal C has mean diagonal about 1 already).

The first column of C is fixed to the image of the constant function,
C_{:,0} = ±√(area_2 / area_1) e_0, which excludes the trivial minimizer C = 0. The rest of
the energy without the last term is an exact quadratic, minimized by one dense Cholesky
solve of its k_2 (k_1 − 1) unknowns (``solver="direct"``) or by L-BFGS on the same energy
and gradient (``solver="lbfgs"``, for large k); with w_r > 0, L-BFGS starts from the
quadratic minimizer.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt
import scipy.linalg as sla
import scipy.optimize as so

from ..calculus import grad, rotation
from ..errors import BasisSizeError, ParameterError
from ..mesh.inputs import as_vertex_function
from ..numerics.summary import html_repr, short_repr
from .basis import SpectralBasis
from .fmaps import split_sizes

__all__ = [
    "FunctionalMapEnergy",
    "DescriptorOperators",
    "fit_functional_map",
    "descriptor_operators",
    "orientation_operators",
    "laplacian_mask",
    "DIRECT_MAX_UNKNOWNS",
]

#: Up to this many unknowns k_2 (k_1 − 1), ``solver="auto"`` solves the normal equations
#: densely (Cholesky of a matrix this size squared); above, L-BFGS.
DIRECT_MAX_UNKNOWNS = 3000

ORIENTATIONS = {"preserving": 1.0, "reversing": -1.0, None: 0.0}


def _check_k(basis: SpectralBasis, k: int | None, name: str) -> SpectralBasis:
    if k is None:
        return basis
    k = int(k)
    if not 2 <= k <= basis.k:
        raise BasisSizeError(
            f"{name} has {basis.k} eigenpairs but k = {k} were asked for (need 2 <= k <= "
            f"{basis.k}). Fix: build the SpectralBasis with at least {k} eigenpairs."
        )
    return basis.truncate(k)


def descriptor_operators(basis: SpectralBasis, descriptors: npt.ArrayLike) -> np.ndarray:
    """Multiplication operators Φᵀ A_V diag(f_j) Φ of descriptors: float64 (p, k, k).

    Parameters
    ----------
    basis : SpectralBasis
        k eigenpairs (use :meth:`SpectralBasis.truncate` for fewer).
    descriptors : array_like (n, p)

    Returns
    -------
    float64 (p, k, k), symmetric matrices.
    """
    F = as_vertex_function(basis.mesh, descriptors, "descriptors", columns=True)
    F = F.reshape(F.shape[0], -1)
    phi = basis.eigenvectors  # (n, k)
    n, k, p = phi.shape[0], phi.shape[1], F.shape[1]
    Aphi = basis.mesh.vertex_areas[:, None] * phi  # (n, k)
    iu, ju = np.triu_indices(k)  # the k(k+1)/2 entries of a symmetric matrix
    upper = np.zeros((p, iu.size))
    for rows in column_blocks(n, 8 * iu.size):  # blocks of vertices: memory bounded
        upper += F[rows].T @ (Aphi[rows][:, iu] * phi[rows][:, ju])  # Σ_v f a φ_i φ_j
    out = np.empty((p, k, k))
    out[:, iu, ju] = upper
    out[:, ju, iu] = upper
    return out


#: Bytes of work arrays per block of descriptor columns (:func:`column_blocks`).
BLOCK_BYTES = 64 * 2**20


def column_blocks(p: int, column_bytes: int) -> list[slice]:
    """Slices of ``range(p)`` (columns or rows) whose work arrays (``column_bytes`` per
    index) stay within :data:`BLOCK_BYTES` (at least one index per block)."""
    step = max(1, BLOCK_BYTES // max(column_bytes, 1))
    return [slice(i, min(i + step, p)) for i in range(0, p, step)]


def orientation_operators(
    basis: SpectralBasis, descriptors: npt.ArrayLike, *, normalize: bool = False
) -> np.ndarray:
    """Reduced functional vector fields of the rotated descriptor gradients: (p, k, k).

    P_j = Φᵀ[A_V] D^V_{J grad f_j} Φ (the chapter's eq. 36 reduced as in Azencot et al.
    2013), computed with :func:`fvf.grad`, :func:`fvf.rotation` and
    :meth:`SpectralBasis.reduced_D_many`. On a closed mesh each P_j is skew-symmetric.

    Parameters
    ----------
    basis : SpectralBasis
    descriptors : array_like (n, p)
    normalize : bool
        Use the unit field J grad f_j / |grad f_j| on each face (zero where the gradient
        vanishes) instead of J grad f_j.

    Returns
    -------
    float64 (p, k, k)
    """
    mesh = basis.mesh
    F = as_vertex_function(mesh, descriptors, "descriptors", columns=True)
    F = F.reshape(F.shape[0], -1)
    JGrad = rotation(mesh) @ grad(mesh)
    m, k, p = mesh.n_faces, basis.k, F.shape[1]
    out = np.empty((p, k, k))
    for cols in column_blocks(p, 8 * m * (k + 9)):  # memory bounded whatever m, k and p
        JG = (JGrad @ F[:, cols]).reshape(m, 3, -1)  # (m, 3, q)
        fields = np.ascontiguousarray(np.moveaxis(JG, 2, 0))  # (q, m, 3)
        if normalize:
            norm = np.linalg.norm(fields, axis=2, keepdims=True)
            fields = np.divide(fields, norm, out=np.zeros_like(fields), where=norm > 0)
        out[cols] = basis.reduced_D_many(fields)
    return out


@dataclass(frozen=True, eq=False)
class DescriptorOperators:
    """The reduced operators of descriptor columns on one basis, kept for several fits.

    A fit at size k uses the leading k × k blocks (the entry (i, j) of either operator
    involves φ_i and φ_j only), so :func:`fvf.match` computes the operators of its
    descriptors once at k_fit for the fit, the two self-maps and the mirror fit (whose
    appended columns add their own); the wide fit, at a larger size, computes its own.

    Attributes
    ----------
    multiplication : float64 (p, k, k)
        :func:`descriptor_operators`.
    orientation : float64 (p, k, k)
        :func:`orientation_operators`.
    """

    __repr__ = short_repr
    _repr_html_ = html_repr

    multiplication: np.ndarray
    orientation: np.ndarray

    @classmethod
    def of(cls, basis: SpectralBasis, descriptors: npt.ArrayLike) -> DescriptorOperators:
        """Both operators of ``descriptors`` (n, p) at the size of ``basis``."""
        return cls(
            descriptor_operators(basis, descriptors), orientation_operators(basis, descriptors)
        )

    @property
    def shape(self) -> tuple[int, int]:
        """(p, k): descriptor columns and basis size."""
        return self.multiplication.shape[0], self.multiplication.shape[1]

    def sized(self, k: int) -> DescriptorOperators:
        """The leading k × k blocks (k at most the size held)."""
        if not 1 <= k <= self.shape[1]:
            raise BasisSizeError(f"operators of size {self.shape[1]} cannot give size {k}")
        return DescriptorOperators(self.multiplication[:, :k, :k], self.orientation[:, :k, :k])

    def scaled(self, sign: float) -> DescriptorOperators:
        """The operators of ``sign`` times the descriptors (both are linear in them)."""
        return DescriptorOperators(sign * self.multiplication, sign * self.orientation)

    def joined(self, other: DescriptorOperators) -> DescriptorOperators:
        """The columns of ``self`` then those of ``other`` (sized to the smaller)."""
        k = min(self.shape[1], other.shape[1])
        a, b = self.sized(k), other.sized(k)
        return DescriptorOperators(
            np.concatenate([a.multiplication, b.multiplication]),
            np.concatenate([a.orientation, b.orientation]),
        )


def laplacian_mask(
    eigenvalues_1: np.ndarray,
    eigenvalues_2: np.ndarray,
    kind: str = "resolvent",
    gamma: float = 0.5,
) -> np.ndarray:
    """Penalty M (k_2, k_1) of the Laplacian-commutativity term Σ M_ij C_ij².

    ``"squared"``: (λ_1j − λ_2i)², the entries of ‖C Λ_1 − Λ_2 C‖²_F (Ovsjanikov et al.
    2012). ``"resolvent"``: |R(λ_1j) − R(λ_2i)|² with R(λ) = 1 / (λ̃^γ − i) and λ̃ = λ /
    max(λ) over both shapes (Ren et al. 2019), bounded in [0, 2) so that high frequencies
    do not dominate.
    """
    l1 = np.abs(np.asarray(eigenvalues_1, float))
    l2 = np.abs(np.asarray(eigenvalues_2, float))
    if kind == "squared":
        return (l1[None, :] - l2[:, None]) ** 2
    if kind != "resolvent":
        raise ParameterError(f"laplacian must be 'resolvent' or 'squared'; got {kind!r}")
    scale = max(l1.max(initial=0.0), l2.max(initial=0.0), 1e-300)

    def resolvent(lam):
        return 1.0 / ((lam / scale) ** gamma - 1j)

    return np.abs(resolvent(l1)[None, :] - resolvent(l2)[:, None]) ** 2


@dataclass
class FunctionalMapEnergy:
    """The quadratic functional-map energy of this module, with its exact minimizer.

    All arrays are reduced to the bases: k_1 on mesh 1, k_2 on mesh 2, p descriptors.
    Build it with :func:`FunctionalMapEnergy.from_descriptors`; weights are
    dimensionless (each term is divided by the mean diagonal τ of its Hessian).

    Attributes
    ----------
    A : float64 (k_1, p)
        Descriptors of mesh 1 in its basis.
    B : float64 (k_2, p)
    mask : float64 (k_2, k_1)
        Laplacian-commutativity penalty.
    pairs : list of (float, (q, k_1, k_1), (q, k_2, k_2))
        Operator-commutativity terms: weight / τ, operators on mesh 1 and (signed) on mesh 2.
    first_column : float64 (k_2,)
        The fixed image of the constant function.
    weights : dict
        The dimensionless weights used.
    """

    __repr__ = short_repr  # arrays by dtype and shape
    _repr_html_ = html_repr  # a table in Jupyter

    A: np.ndarray
    B: np.ndarray
    mask: np.ndarray
    w_descr: float
    w_lap: float
    w_orth: float = 0.0
    pairs: list = field(default_factory=list)
    first_column: np.ndarray | None = None
    weights: dict = field(default_factory=dict)

    # ------------------------------------------------------------------ construction
    @classmethod
    def from_descriptors(
        cls,
        basis_1: SpectralBasis,
        basis_2: SpectralBasis,
        descr_1: npt.ArrayLike,
        descr_2: npt.ArrayLike,
        *,
        w_descr: float = 1.0,
        w_lap: float = 1.0,
        w_dcomm: float = 1.0,
        w_orient: float = 1.0,
        w_orth: float = 0.0,
        orientation: str | None = "preserving",
        laplacian: str = "resolvent",
        operators: tuple[DescriptorOperators, DescriptorOperators] | None = None,
    ) -> FunctionalMapEnergy:
        """Reduce descriptors and build every term (see the module docstring).

        Parameters
        ----------
        basis_1, basis_2 : SpectralBasis
            k_1 and k_2 eigenpairs (the size of C is (k_2, k_1)).
        descr_1 : array_like (n_1, p)
        descr_2 : array_like (n_2, p)
            Corresponding descriptor columns.
        w_descr, w_lap, w_dcomm, w_orient : float
            Non-negative dimensionless weights.
        orientation : {"preserving", "reversing", None}
            Sign s of the orientation term, or None to leave it out.
        laplacian : {"resolvent", "squared"}
        operators : (DescriptorOperators, DescriptorOperators), optional
            The descriptors' operators on mesh 1 and mesh 2, already computed at sizes
            of at least k_1 and k_2 (default: computed here).

        Raises
        ------
        BasisSizeError
            Descriptor arrays with different column counts, or operators of other
            descriptors or too small.
        ParameterError
            A negative or non-finite weight, or an unknown option.
        """
        weights = {
            "descr": w_descr,
            "lap": w_lap,
            "dcomm": w_dcomm,
            "orient": w_orient,
            "orth": w_orth,
        }
        for name, w in weights.items():
            if not (np.isfinite(w) and w >= 0):
                raise ParameterError(f"w_{name} must be a finite number >= 0; got {w!r}")
        if orientation not in ORIENTATIONS:
            raise ParameterError(
                f"orientation must be 'preserving', 'reversing' or None; got {orientation!r}"
            )
        F = as_vertex_function(basis_1.mesh, descr_1, "descr_1", columns=True)
        G = as_vertex_function(basis_2.mesh, descr_2, "descr_2", columns=True)
        F, G = F.reshape(F.shape[0], -1), G.reshape(G.shape[0], -1)
        if F.shape[1] != G.shape[1]:
            raise BasisSizeError(
                f"descr_1 has {F.shape[1]} columns and descr_2 has {G.shape[1]}; "
                "descriptors must correspond column by column."
            )
        A, B = basis_1.project(F), basis_2.project(G)  # (k1, p), (k2, p)
        k1, k2 = basis_1.k, basis_2.k
        mask = laplacian_mask(basis_1.eigenvalues, basis_2.eigenvalues, laplacian)
        tau_d = k2 * float((A * A).sum()) / (k1 * k2)
        tau_l = float(mask.sum()) / (k1 * k2)
        energy = cls(
            A=A,
            B=B,
            mask=mask,
            w_descr=w_descr / tau_d if tau_d > 0 else 0.0,
            w_lap=w_lap / tau_l if tau_l > 0 else 0.0,
            w_orth=float(w_orth),
            weights=dict(weights, orientation=orientation, laplacian=laplacian),
        )
        if operators is not None:
            o1, o2 = _given_operators(operators, F.shape[1], k1, k2)
        if w_dcomm > 0:
            if operators is None:
                X, Y = _operator_pair(descriptor_operators, basis_1, basis_2, F, G)
            else:
                X, Y = o1.multiplication, o2.multiplication
            energy.add_pair(w_dcomm, X, Y)
        sign = ORIENTATIONS[orientation]
        if w_orient > 0 and sign != 0:
            if operators is None:
                P, Q = _operator_pair(orientation_operators, basis_1, basis_2, F, G)
            else:
                P, Q = o1.orientation, o2.orientation
            energy.add_pair(w_orient, P, sign * Q)
        phi1_0, phi2_0 = basis_1.eigenvectors[0, 0], basis_2.eigenvectors[0, 0]
        c0 = np.zeros(k2)
        area_1, area_2 = basis_1.mesh.total_area, basis_2.mesh.total_area
        c0[0] = np.sign(phi1_0 * phi2_0) * np.sqrt(area_2 / area_1)
        energy.first_column = c0
        return energy

    def add_pair(self, weight: float, ops_1: np.ndarray, ops_2: np.ndarray) -> None:
        """Add w Σ_j ‖C X_j − Y_j C‖² / τ for operators X (q, k_1, k_1), Y (q, k_2, k_2)."""
        k1, k2 = self.A.shape[0], self.B.shape[0]
        if ops_1.shape[1:] != (k1, k1) or ops_2.shape[1:] != (k2, k2):
            raise BasisSizeError(
                f"operators must be (q, {k1}, {k1}) and (q, {k2}, {k2}); got "
                f"{ops_1.shape} and {ops_2.shape}"
            )
        tr1 = np.einsum("qii->q", ops_1)
        tr2 = np.einsum("qii->q", ops_2)
        tau = (k2 * (ops_1**2).sum() + k1 * (ops_2**2).sum() - 2 * (tr1 * tr2).sum()) / (k1 * k2)
        if tau > 0 and weight > 0:
            self.pairs.append((weight / float(tau), ops_1, ops_2))

    # ------------------------------------------------------------------ evaluation
    @property
    def shape(self) -> tuple[int, int]:
        """(k_2, k_1): the shape of C."""
        return self.B.shape[0], self.A.shape[0]

    def value(self, C: np.ndarray) -> float:
        """E(C) (the constant first column is not imposed here)."""
        r = C @ self.A - self.B
        e = self.w_descr * (r * r).sum() + self.w_lap * (self.mask * C * C).sum()
        if self.w_orth:
            G = C.T @ C - np.eye(C.shape[1])
            e += 0.5 * self.w_orth * (G * G).sum()
        for w, X, Y in self.pairs:
            R = C @ X - Y @ C  # (q, k2, k1)
            e += w * (R * R).sum()
        return 0.5 * float(e)

    def gradient(self, C: np.ndarray) -> np.ndarray:
        """∂E/∂C, float64 (k_2, k_1)."""
        g = self.w_descr * (C @ self.A - self.B) @ self.A.T + self.w_lap * self.mask * C
        if self.w_orth:
            g += self.w_orth * C @ (C.T @ C - np.eye(C.shape[1]))
        for w, X, Y in self.pairs:
            R = C @ X - Y @ C
            g += w * (R @ X.transpose(0, 2, 1) - Y.transpose(0, 2, 1) @ R).sum(axis=0)
        return g

    def hessian(self) -> tuple[np.ndarray, np.ndarray]:
        """The normal equations H vec(C) = b of E (row-major vec), dense.

        Returns
        -------
        H : float64 (k_2 k_1, k_2 k_1)
        b : float64 (k_2 k_1,)
        """
        k2, k1 = self.shape
        I1, I2 = np.eye(k1), np.eye(k2)
        H = self.w_descr * np.kron(I2, self.A @ self.A.T)
        H[np.diag_indices_from(H)] += self.w_lap * self.mask.ravel()
        for w, X, Y in self.pairs:
            H += w * np.kron(I2, np.einsum("qab,qcb->ac", X, X))  # Σ X Xᵀ
            H += w * np.kron(np.einsum("qba,qbc->ac", Y, Y), I1)  # Σ Yᵀ Y
            # Σ_q Y_q ⊗ X_q as one (k2², q) x (q, k1²) product
            T = (Y.reshape(len(Y), -1).T @ X.reshape(len(X), -1)).reshape(k2, k2, k1, k1)
            T = T.transpose(0, 2, 1, 3).reshape(k2 * k1, k2 * k1)
            H -= w * (T + T.T)
        b = self.w_descr * (self.B @ self.A.T).ravel()
        return H, b

    # ------------------------------------------------------------------ minimization
    def minimize(self, solver: str = "auto", C0: np.ndarray | None = None) -> np.ndarray:
        """The minimizer of E with the first column fixed: float64 (k_2, k_1).

        Parameters
        ----------
        solver : {"auto", "direct", "lbfgs"}
            ``"direct"``: Cholesky of the reduced normal equations (exact);
            ``"lbfgs"``: scipy's L-BFGS-B on E and its gradient, from C0 (default zeros),
            to a projected gradient of 1e-10 relative; ``"auto"``: direct up to
            :data:`DIRECT_MAX_UNKNOWNS` unknowns. With the non-quadratic ``w_orth`` term,
            ``"direct"`` means L-BFGS-B started from the quadratic terms' exact minimizer.
        C0 : float64 (k_2, k_1), optional
            Start of L-BFGS-B.

        Returns
        -------
        float64 (k_2, k_1)
        """
        k2, k1 = self.shape
        c0 = self.first_column if self.first_column is not None else np.zeros(k2)
        if solver == "auto":
            solver = "direct" if k2 * (k1 - 1) <= DIRECT_MAX_UNKNOWNS else "lbfgs"
        if solver == "direct":
            H, b = self.hessian()
            C = self._quadratic_minimizer(c0, H, b)
            return self._lbfgs(c0, C, (H, b)) if self.w_orth else C
        if solver != "lbfgs":
            raise ParameterError(f"solver must be 'auto', 'direct' or 'lbfgs'; got {solver!r}")
        return self._lbfgs(c0, C0)

    def _quadratic_minimizer(self, c0: np.ndarray, H: np.ndarray, b: np.ndarray) -> np.ndarray:
        """Exact minimizer of the quadratic terms (w_orth ignored), first column c0, from
        the normal equations H, b of :meth:`hessian`."""
        k2, k1 = self.shape
        free = (np.arange(k2 * k1) % k1) != 0  # every column but the first
        rhs = b[free] - H[np.ix_(free, ~free)] @ c0
        Hff = H[np.ix_(free, free)]
        try:
            x = sla.cho_solve(sla.cho_factor(Hff, lower=True, check_finite=False), rhs)
        except np.linalg.LinAlgError:  # semidefinite (e.g. all weights zero but one)
            x = sla.lstsq(Hff, rhs, check_finite=False)[0]
        return np.concatenate([c0[:, None], x.reshape(k2, k1 - 1)], axis=1)

    def _lbfgs(
        self,
        c0: np.ndarray,
        C0: np.ndarray | None,
        normal: tuple[np.ndarray, np.ndarray] | None = None,
    ) -> np.ndarray:
        """L-BFGS-B on E over every column but the first (fixed to c0), from C0.

        With the normal equations ``normal`` = (H, b) of :meth:`hessian`, the quadratic
        terms and their gradient are ½ xᵀHx − bᵀx and Hx − b (one dense product instead
        of the operator terms; E up to a constant, the same minimizer); only the
        orthogonality term is evaluated from C."""
        k2, k1 = self.shape
        start = np.zeros((k2, k1)) if C0 is None else np.array(C0, dtype=float)
        start[:, 0] = c0

        def full(x):
            return np.concatenate([c0[:, None], x.reshape(k2, k1 - 1)], axis=1)

        if normal is None:

            def fun(x):
                C = full(x)
                return self.value(C), self.gradient(C)[:, 1:].ravel()

        else:
            H, b = normal

            def fun(x):
                C = full(x)
                Hx = H @ C.ravel()
                G = C.T @ C - np.eye(k1)
                value = 0.5 * C.ravel() @ Hx - b @ C.ravel() + 0.25 * self.w_orth * (G * G).sum()
                grad = (Hx - b).reshape(k2, k1) + self.w_orth * C @ G
                return float(value), grad[:, 1:].ravel()

        g0 = np.abs(fun(start[:, 1:].ravel())[1]).max()
        res = so.minimize(
            fun,
            start[:, 1:].ravel(),
            jac=True,
            method="L-BFGS-B",
            options={"maxiter": 5000, "ftol": 1e-15, "gtol": 1e-10 * max(g0, 1e-300)},
        )
        return full(res.x)


def _given_operators(
    operators: tuple[DescriptorOperators, DescriptorOperators], p: int, k1: int, k2: int
) -> tuple[DescriptorOperators, DescriptorOperators]:
    """The caller's operators, checked against p columns and sized to (k_1, k_2)."""
    out = []
    for ops, k, name in zip(operators, (k1, k2), ("mesh 1", "mesh 2"), strict=True):
        if ops.shape[0] != p or ops.shape[1] < k:
            raise BasisSizeError(
                f"the operators given for {name} hold {ops.shape[0]} descriptors at size "
                f"{ops.shape[1]}; the fit needs {p} at size {k} or more"
            )
        out.append(ops.sized(k))
    return out[0], out[1]


def _operator_pair(
    operators: Callable[[SpectralBasis, np.ndarray], np.ndarray],
    basis_1: SpectralBasis,
    basis_2: SpectralBasis,
    F: np.ndarray,
    G: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """``operators`` of F on mesh 1 and of G on mesh 2, (p, k, k) each.

    Both kinds of operator are linear in the descriptor, so on a self-map (one mesh, one
    basis size) whose columns of G are ± those of F, mesh 2's operators are ± mesh 1's.
    """
    X = operators(basis_1, F)
    same = basis_2.mesh is basis_1.mesh and basis_2.k == basis_1.k and F.shape == G.shape
    if same:
        plus, minus = np.all(G == F, axis=0), np.all(G == -F, axis=0)
        if np.all(plus | minus):
            return X, np.where(plus, 1.0, -1.0)[:, None, None] * X
    return X, operators(basis_2, G)


def fit_functional_map(
    basis_1: SpectralBasis,
    basis_2: SpectralBasis,
    descr_1: npt.ArrayLike,
    descr_2: npt.ArrayLike,
    *,
    k: int | tuple[int, int] | None = None,
    w_descr: float = 1.0,
    w_lap: float = 1.0,
    w_dcomm: float = 1.0,
    w_orient: float = 1.0,
    w_orth: float = 0.0,
    orientation: str | None = "preserving",
    laplacian: str = "resolvent",
    solver: str = "auto",
    operators: tuple[DescriptorOperators, DescriptorOperators] | None = None,
) -> np.ndarray:
    """The functional map C_12 that best preserves descriptors (see the module docstring).

    Parameters
    ----------
    basis_1, basis_2 : SpectralBasis
        Bases of mesh 1 and mesh 2 (with at least k_1 and k_2 eigenpairs).
    descr_1 : array_like (n_1, p)
    descr_2 : array_like (n_2, p)
        Corresponding descriptors, e.g. :func:`fvf.wave_kernel_signature` on each mesh
        with the same energies.
    k : int or (k_1, k_2), optional
        Size of the map (default: all eigenpairs of each basis).
    w_descr, w_lap, w_dcomm, w_orient : float
        Dimensionless weights of descriptor preservation, Laplacian commutativity,
        descriptor commutativity and the orientation term.
    orientation : {"preserving", "reversing", None}
        ``"preserving"`` for a map between two shapes, ``"reversing"`` for a left-right
        self-symmetry, None to drop the orientation term.
    laplacian : {"resolvent", "squared"}
        Penalty of the Laplacian commutativity (:func:`laplacian_mask`).
    solver : {"auto", "direct", "lbfgs"}
    operators : (DescriptorOperators, DescriptorOperators), optional
        The descriptors' operators on each mesh at a size of at least k_1 and k_2, to
        share among several fits (default: computed here).

    Returns
    -------
    C_12 : float64 (k_2, k_1)
        Coefficients on mesh 1 -> coefficients on mesh 2; pair it with
        :func:`fvf.p2p_from_functional_map` for a vertex map.

    Raises
    ------
    BasisSizeError
        k larger than a basis, or descriptor arrays that do not correspond.
    ParameterError
        A negative weight or an unknown option.
    """
    k1, k2 = split_sizes(k)
    b1 = _check_k(basis_1, k1, "basis_1")
    b2 = _check_k(basis_2, k2, "basis_2")
    energy = FunctionalMapEnergy.from_descriptors(
        b1,
        b2,
        descr_1,
        descr_2,
        w_descr=w_descr,
        w_lap=w_lap,
        w_dcomm=w_dcomm,
        w_orient=w_orient,
        w_orth=w_orth,
        orientation=orientation,
        laplacian=laplacian,
        operators=operators,
    )
    return energy.minimize(solver)
