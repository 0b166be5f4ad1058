"""Meshes: the validated :class:`TriMesh`, checks of user arrays against it, repairs,
diagnostics, generated shapes and the built-in meshes.

Where things go: a new mesh quality check goes to :mod:`.diagnostics`, a new repair to
:mod:`.repair`, a new generated surface to :mod:`.shapes`.
"""

from .builtin import spot, spot_path
from .convert import MeshLike, as_mesh, register_path_reader, takes_mesh
from .curvature import PrincipalCurvatures, principal_curvatures, vertex_normals
from .diagnostics import mesh_report
from .inputs import as_face_field, as_face_function, as_vertex_function
from .nfield import NField
from .prepared import PreparedMesh, prepare_mesh
from .repair import (
    RepairResult,
    flatten_spikes,
    orient_faces,
    remove_degenerate_faces,
    remove_duplicate_faces,
    remove_duplicate_vertices,
    remove_unreferenced_vertices,
    repair_mesh,
    split_nonmanifold_edges,
    split_nonmanifold_vertices,
    split_t_junctions,
)
from .shapes import disk, icosphere, jittered_sphere, midpoint_subdivision, torus
from .trimesh import TriMesh

__all__ = [
    "TriMesh",
    "MeshLike",
    "as_mesh",
    "takes_mesh",
    "register_path_reader",
    "PrincipalCurvatures",
    "principal_curvatures",
    "vertex_normals",
    "as_vertex_function",
    "as_face_function",
    "as_face_field",
    "NField",
    "PreparedMesh",
    "prepare_mesh",
    "RepairResult",
    "repair_mesh",
    "remove_unreferenced_vertices",
    "remove_duplicate_vertices",
    "remove_degenerate_faces",
    "remove_duplicate_faces",
    "orient_faces",
    "split_nonmanifold_vertices",
    "split_nonmanifold_edges",
    "flatten_spikes",
    "split_t_junctions",
    "mesh_report",
    "icosphere",
    "jittered_sphere",
    "torus",
    "disk",
    "midpoint_subdivision",
    "spot",
    "spot_path",
]

#: Names of ``__all__`` that the flat namespace ``fvf`` leaves out (reach them as
#: ``fvf.mesh.name``); every other name here is also ``fvf.name``.
NOT_FLAT: frozenset[str] = frozenset(
    {
        "PreparedMesh",
        "PrincipalCurvatures",
        "mesh_report",
        "midpoint_subdivision",
        "prepare_mesh",
        "register_path_reader",
        "spot_path",
        "takes_mesh",
        "vertex_normals",
    }
)
