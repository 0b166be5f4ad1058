"""Typed errors and warnings raised by fvf.

Every user-facing error is a :class:`ValueError` subclass whose message names the
offending indices (at most a handful, then a count) and says how to fix the input.
Recoverable trouble is reported with :func:`warnings.warn` and one of the
:class:`FvfWarning` subclasses, never printed.
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "FvfError",
    "FvfWarning",
    "MeshError",
    "MeshShapeError",
    "MeshIndexError",
    "NonFiniteError",
    "DegenerateFaceError",
    "RepeatedVertexError",
    "UnreferencedVertexError",
    "NonManifoldError",
    "OrientationError",
    "NonOrientableError",
    "MeshReadError",
    "PolygonTriangulatedWarning",
    "MeshReadWarning",
    "MeshFormatError",
    "VerticesWeldedWarning",
    "MeshScaleError",
    "DuplicateVertexWarning",
    "UndeclaredCacheKeyError",
    "FieldError",
    "FieldShapeError",
    "FieldValueError",
    "NonTangentFieldWarning",
    "ZeroFieldWarning",
    "ParameterError",
    "ProblemSizeError",
    "FlowOverflowError",
    "FlowGrowthWarning",
    "ExpmInputError",
    "KrylovFallbackWarning",
    "FluidSolveError",
    "SpectralInputError",
    "SpectralSolveError",
    "SpectralFallbackWarning",
    "FactorizationError",
    "FactorizationFallbackWarning",
    "ConstraintError",
    "ConstraintIndexError",
    "ZeroDirectionError",
    "NormalDirectionError",
    "ConflictingConstraintError",
    "PointLocationError",
    "UnconstrainedComponentWarning",
    "DataFileError",
    "DataKeyError",
    "MeshMismatchError",
    "LegacyLayoutWarning",
    "MissingExtraError",
    "NoDisplayError",
    "RenderBackendWarning",
    "OutputError",
    "InputOverwriteError",
    "OutputWriteError",
    "BatchInputError",
    "BatchOutputError",
    "BatchWarning",
    "ParameterizationInputError",
    "FlippedParameterizationWarning",
    "QuadExtractionError",
    "QuadMeshError",
    "SmallComponentWarning",
    "DirectionCountError",
    "DirectionCountConflictError",
    "CutGraphError",
    "FrameError",
    "CorrespondenceError",
    "LandmarkError",
    "BasisSizeError",
    "DisconnectedMeshError",
    "NotEnoughEigenpairsError",
    "FoldedQuadWarning",
    "QuadCountRaisedWarning",
    "DenseFeaturesWarning",
    "DistortedQuadsWarning",
    "QuadFallbackWarning",
    "format_indices",
]

#: Every name of ``__all__`` is also ``fvf.name`` (the flat namespace leaves none out).
NOT_FLAT: frozenset[str] = frozenset()


# ---------------------------------------------------------------------------- base classes
class FvfError(ValueError):
    """Base class of every error fvf raises on bad input."""


class FvfWarning(UserWarning):
    """Base class of every warning fvf emits."""


# ---------------------------------------------------------------------------- meshes
class MeshError(FvfError):
    """The vertices or faces given to :class:`fvf.TriMesh` are not a valid mesh."""


class MeshShapeError(MeshError):
    """Vertices or faces have the wrong shape or dtype."""


class MeshIndexError(MeshError):
    """A face refers to a vertex index outside ``[0, n)`` or repeats a vertex."""


class NonFiniteError(MeshError):
    """Vertex coordinates (or another input array) contain NaN or inf."""


class DegenerateFaceError(MeshError):
    """Some faces have zero area, so their gradient and normal are undefined."""


class RepeatedVertexError(MeshIndexError, DegenerateFaceError):
    """Some faces name one vertex twice (a zero-area STL facet welded shut, a polygon that
    repeats its first vertex at its end): degenerate faces that ``fvf repair`` and
    :func:`fvf.remove_degenerate_faces` drop."""


class UnreferencedVertexError(MeshError):
    """Some vertices belong to no face, so their vertex area is zero."""


class NonManifoldError(MeshError):
    """An edge is shared by more than two faces, or a vertex's faces form several fans."""


class OrientationError(MeshError):
    """Two faces sharing an edge traverse it in the same direction."""


class NonOrientableError(OrientationError):
    """No orientation of the faces exists (a Moebius strip, a Klein bottle): no repair
    makes the normals consistent."""


class MeshReadError(FvfError):
    """A mesh file could not be parsed."""


class MeshReadWarning(FvfWarning):
    """Part of a mesh file was left out as it was read (a glTF file's primitives that are
    not triangles); the message says which and how to keep them."""


class PolygonTriangulatedWarning(FvfWarning):
    """The file had polygons with more than 3 vertices; they were fan-triangulated (the
    non-convex ones whose fan would fold over: split otherwise)."""


class MeshFormatError(FvfError):
    """A mesh file format cannot do what was asked: the suffix names no format fvf
    writes, or the format cannot hold the faces (e.g. quads in STL) or the vertex and
    face data given. Raised before anything is computed or written
    (:func:`fvf.io.check_writable`)."""


class VerticesWeldedWarning(FvfWarning):
    """A triangle-soup file (STL) was read: facet corners at exactly the same position
    were welded into shared vertices; the message says how many."""


class MeshScaleError(MeshError):
    """The coordinates are so large (or so small) that face areas overflow (or underflow)
    float64; rescale the vertices."""


class DuplicateVertexWarning(FvfWarning):
    """Many vertices sit at the position of another vertex and the mesh falls apart into
    pieces along them (a triangle soup, or a mesh split at UV seams); weld them with
    :func:`fvf.remove_duplicate_vertices`."""


class UndeclaredCacheKeyError(FvfError):
    """A value cached on a TriMesh under a name not declared in
    :data:`fvf.mesh.cache.CACHED_QUANTITIES` (a mistake in fvf or in an extension)."""


# ---------------------------------------------------------------------------- functions and fields
class FieldError(FvfError):
    """A function or vector field given to fvf cannot be used (base class)."""


class FieldShapeError(FieldError):
    """A function or vector field has the wrong shape or dtype."""


class FieldValueError(FieldError):
    """A function or vector field has values fvf cannot use: NaN or inf entries, or
    magnitudes out of floating-point reach."""


class NonTangentFieldWarning(FvfWarning):
    """A per-face field had a normal component, which was projected away."""


class ZeroFieldWarning(FvfWarning):
    """A field had (numerically) zero vectors; the indices next to them were set to 0."""


# ---------------------------------------------------------------------------- options
class ParameterError(FvfError):
    """A scalar or option argument is invalid: a non-finite or out-of-range time, step,
    weight, tolerance or count, or an unknown option name (the message lists the valid
    ones)."""


def thread_limit_text(exc: BaseException) -> str | None:
    """The message for Python's ``RuntimeError("can't start new thread")`` (an address-space
    or process limit, ``ulimit -v`` / ``ulimit -u``, too small for the threads of a
    solver or of Dask), else None."""
    if isinstance(exc, RuntimeError) and "can't start new thread" in str(exc):
        return (
            "cannot start another thread: the memory (ulimit -v) or process (ulimit -u) "
            "limit is too small for the threads of the solvers and of Dask. Fix: raise the "
            "limit, or run fewer workers (--workers 1) with OMP_NUM_THREADS=1"
        )
    return None


class ProblemSizeError(ParameterError):
    """A requested size (quads, vertices, eigenpairs) would need more memory than the
    machine has, or more than the input can carry; refused before anything is allocated
    (the message gives the estimate and what to change)."""


# ---------------------------------------------------------------------------- flows
class FlowOverflowError(FvfError, FloatingPointError):
    """A flow or exponential action cannot be computed in floating point: its values
    overflow, or the time is so long (|t| times the operator's norm) that the steps it
    needs underflow. Also a :class:`FloatingPointError`."""


class FlowGrowthWarning(FvfWarning):
    """A flow is estimated (or observed) to grow a function's norm beyond the limit."""


class ExpmInputError(ParameterError):
    """Bad input to :func:`fvf.numerics.expm_action` (and to the flows' times): shapes,
    non-finite values, weights, tol, method. A :class:`ParameterError`."""


class KrylovFallbackWarning(FvfWarning):
    """``skew=True`` was passed but the operator is not skew-adjoint; the general method
    was used."""


class FluidSolveError(FvfError, RuntimeError):
    """The implicit midpoint equation of a step could not be solved (step too long)."""


# ---------------------------------------------------------------------------- spectra
class SpectralInputError(FvfError):
    """Bad input to :func:`fvf.smallest_eigenpairs` (shapes, k, tol, non-finite or
    mass ≤ 0)."""


class SpectralSolveError(FvfError, RuntimeError):
    """An eigensolver failed to compute the eigenpairs (for :func:`fvf.smallest_eigenpairs`:
    every method of its fallback chain failed)."""


class SpectralFallbackWarning(FvfWarning):
    """The requested eigensolver failed; another one was used (the message says which)."""


class FactorizationError(SpectralSolveError):
    """A sparse factorization (:mod:`fvf.numerics.cholesky`) failed: the matrix is singular
    or not positive definite, or the backend gave up (the message names the backend and
    its reason). A :class:`SpectralSolveError`, so also a :class:`RuntimeError`."""


class FactorizationFallbackWarning(FvfWarning):
    """A factorization backend chosen by ``backend="auto"`` failed; the next one was used
    (the message says which and why)."""


# ---------------------------------------------------------------------------- design
class ConstraintError(FvfError):
    """Design constraints are malformed (shapes, weights, missing arguments)."""


class ConstraintIndexError(ConstraintError):
    """A constraint refers to a face index outside ``[0, m)``."""


class ZeroDirectionError(ConstraintError):
    """A constraint direction is the zero vector, so it prescribes no direction."""


class NormalDirectionError(ConstraintError):
    """A constraint direction is (nearly) normal to its face: its tangent part vanishes."""


class ConflictingConstraintError(ConstraintError):
    """The same face is constrained twice with different targets."""


class PointLocationError(ConstraintError):
    """Barycentric coordinates do not describe a point of their face."""


class UnconstrainedComponentWarning(FvfWarning):
    """A connected component of the mesh has no constraint; the field is zero there."""


# ---------------------------------------------------------------------------- N-direction fields
class DirectionCountError(ParameterError):
    """The symmetry order N of an N-direction field is not an integer >= 1, or does not
    fit the request (curvature alignment needs an even N)."""


class DirectionCountConflictError(DirectionCountError):
    """An explicit ``n=`` contradicts the N that an :class:`fvf.NField` carries (or a file
    stores for it); drop ``n=``, or pass the bare array ``np.asarray(field)``."""


class CutGraphError(FvfError):
    """A cut given to :func:`fvf.comb` is malformed (shape, edges not in the mesh) or does
    not make the field combable (an uncut edge would keep a period jump)."""


class FrameError(FvfError):
    """A frame (u, v) given to :func:`fvf.rescale_frame` is not usable: the two fields are
    parallel or zero on some faces."""


# ---------------------------------------------------------------------------- data files
class DataFileError(FvfError):
    """A data file (``.npz`` or ``.ply``) cannot be read."""


class DataKeyError(DataFileError):
    """A data file lacks a key the command needs."""


class MeshMismatchError(DataFileError):
    """The mesh copy stored in a data file (``vertices``, ``faces``) differs from the mesh."""


class LegacyLayoutWarning(FvfWarning):
    """A data file stores several functions as rows, (k, n), the layout of files from
    older fvf versions; it was read transposed, as (n, k), one column per function."""


# ---------------------------------------------------------------------------- pictures
class MissingExtraError(FvfError, ImportError):
    """A package of an optional extra (e.g. ``[viz]``: matplotlib, pillow, polyscope) is
    missing."""


class NoDisplayError(FvfError):
    """An interactive window was asked for where no display exists."""


class RenderBackendWarning(FvfWarning):
    """A rendering backend failed to start; fvf fell back to the next one."""


# ---------------------------------------------------------------------------- output files
class OutputError(FvfError):
    """An output file cannot be written where asked (base class)."""


class InputOverwriteError(OutputError):
    """An output path is an input file of the same command (the same path, a hard link
    or a symbolic link to it); fvf never replaces its inputs unless told to (``--force``,
    ``overwrite_inputs=True``)."""


class OutputWriteError(OutputError):
    """Writing an output failed (disk full, file size limit, read-only file system, no
    permission). Nothing was written: a file already at the path is unchanged."""


# ---------------------------------------------------------------------------- batch processing
class BatchInputError(FvfError):
    """The inputs of :func:`fvf.batch.run` cannot be used: a path that does not exist, a
    folder or pattern without a mesh file, a malformed pairs file, or a Dask scheduler that
    cannot be reached."""


class BatchOutputError(FvfError):
    """The output folder of :func:`fvf.batch.run` cannot be used: it is not a folder, or
    another batch is writing into it (its lock is held)."""


class BatchWarning(FvfWarning):
    """A batch runs, but not as documented: e.g. the cluster's workers have several threads
    and declare no ``MESH`` resource, so a worker may hold several meshes at once."""


# ---------------------------------------------------------------------------- correspondence
class CorrespondenceError(FvfError):
    """Bad input to shape correspondence (descriptors, functional-map fitting, matching)."""


class LandmarkError(CorrespondenceError):
    """Landmark vertex indices out of range, repeated, or not paired between the meshes."""


class BasisSizeError(CorrespondenceError):
    """A spectral basis, descriptor array or functional map has other sizes than asked."""


class DisconnectedMeshError(CorrespondenceError):
    """A mesh to match has several connected components (one shape is expected)."""


class NotEnoughEigenpairsError(CorrespondenceError):
    """A mesh has too few vertices for the number of eigenfunctions asked for."""


def user_stacklevel() -> int:
    """The ``stacklevel`` for :func:`warnings.warn` that points at the first frame outside
    the fvf package (the user's call), however deep inside fvf the warning is raised."""
    import sys
    from pathlib import Path
    from types import FrameType

    package = str(Path(__file__).resolve().parent)
    frame: FrameType | None = sys._getframe(1)  # the caller of user_stacklevel() is level 1
    level = 1
    while frame is not None and str(Path(frame.f_code.co_filename).resolve()).startswith(package):
        frame, level = frame.f_back, level + 1
    return level


# ---------------------------------------------------------------------------- quads
class ParameterizationInputError(FvfError):
    """A mesh or cross field the seamless parameterization cannot handle (boundary,
    several components, cones of unsupported index). ``where`` (float64 (k, 3), or None)
    holds the points it names, when it names any (the cones)."""

    where: object = None


class FlippedParameterizationWarning(FvfWarning):
    """Some uv triangles of a parameterization are flipped or degenerate."""


class QuadExtractionError(FvfError, RuntimeError):
    """Quad extraction met a parameterization it cannot turn into a valid quad mesh
    (flipped or degenerate uv triangles, a target too coarse for the topology).
    ``where`` (float64 (k, 3), or None) holds the points where it failed, when known."""

    where: object = None


class QuadMeshError(QuadExtractionError):
    """:func:`fvf.quad_mesh` found no valid quad mesh: every attempt (the input, the
    input remeshed at the quad scale, the smoothest field, more quads) gave a mesh that
    fails a validity check or failed itself. ``attempts`` lists each attempt and why it
    failed; ``best`` is the least bad quad mesh seen (or None), for inspection only;
    ``places`` the places where attempts failed, most failed attempts first, with how many
    failed there and the input's thickness (:class:`fvf.param.quad_failures.Place`), and
    ``where`` (float64 (k, 3)) their centres."""

    def __init__(
        self, message: str, attempts: tuple = (), best: object = None, places: tuple = ()
    ) -> None:
        super().__init__(message)
        self.attempts = tuple(attempts)
        self.best = best
        self.places = tuple(places)
        self.where = np.array([p.centre for p in self.places], dtype=np.float64).reshape(-1, 3)


class SmallComponentWarning(FvfWarning):
    """Small connected components were left out: of a quad mesh, those too small for the
    quad size (the message names them and gives their areas in target quads); of a mesh
    prepared for matching (:func:`fvf.mesh.prepare_mesh`, :func:`fvf.match`), specks of
    at most 1 % of the vertices beside the one shape (the message gives their sizes)."""


# ---------------------------------------------------------------------------- folded quads
class QuadCountRaisedWarning(FvfWarning):
    """A component of a quad mesh was meshed with more quads than asked: every attempt at
    the size asked failed at parts of the surface narrower than a quad edge (a finger, a
    spike), and quads small enough for them succeeded; the message says where and how
    many."""


class DenseFeaturesWarning(FvfWarning):
    """A component's sharp edges are denser than the quads can follow (a thread, a knurl:
    longer than all edges of quads of edge ``h``, about twice the area over ``h``,
    :data:`fvf.param.features.DENSE_FEATURES`): they are neither iso-lines nor held, and
    the component is meshed as a smooth surface; the message gives the density and the
    quad count at which they would be followed."""


class DistortedQuadsWarning(FvfWarning):
    """A component of a quad mesh is valid but distorted (corner angles far from 90°, as
    an input's long fan triangles can leave it): no later attempt gave an undistorted
    one; the message gives the measure and what to try."""


class QuadFallbackWarning(FvfWarning):
    """With ``fvf.quad_mesh(..., fallback="split")``: no field-aligned attempt on a
    component passed the gate, and its triangles were split into three quads each
    (valid quads that follow no field); the message names the component, where the
    attempts failed and the quads made."""


class FoldedQuadWarning(FvfWarning):
    """Quads of a quad mesh stay folded in 3D (normal against the input surface's) after
    the untangling on the surface; the message names them."""


def format_indices(idx: object, limit: int = 8) -> str:
    """Format an index list for an error message: the first few and a count.

    Parameters
    ----------
    idx : array_like of int, shape (k,)
        Offending indices.
    limit : int
        How many to print before summarising.

    Returns
    -------
    str
        For example ``"[3, 17, 42] (3 in all)"``.
    """
    idx = np.asarray(idx).ravel()
    shown = ", ".join(str(int(i)) for i in idx[:limit])
    more = ", ..." if idx.size > limit else ""
    return f"[{shown}{more}] ({idx.size} in all)"
