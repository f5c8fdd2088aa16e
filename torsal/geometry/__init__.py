"""Geometry: meshes, discrete line congruences, torsal curves, support structures."""
from .congruence import Congruence, FaceFrame
from .mesh import (
    MeshError,
    average_edge_length,
    boundary_vertices,
    edge_face_adjacency,
    load_mesh,
    umbrella_laplacian,
    validate_mesh,
    vertex_normals,
)
from .support import FinStrip, SupportStructure, fin_planarity
from .torsal_curves import TorsalCurve, trace_torsal_curve

__all__ = [
    "Congruence", "FaceFrame", "MeshError", "load_mesh", "validate_mesh", "average_edge_length",
    "vertex_normals", "umbrella_laplacian", "boundary_vertices", "edge_face_adjacency",
    "SupportStructure", "FinStrip", "fin_planarity", "TorsalCurve", "trace_torsal_curve",
]
