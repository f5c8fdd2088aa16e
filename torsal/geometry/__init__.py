"""Geometry: meshes, discrete line congruences, torsal curves, support structures."""
from .congruence import Congruence, FaceFrame
from .optimize import CongruenceProblem, OptimizationError, OptimizationResult
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
from .developable import refine_developable
from .frame_field import FrameFieldError, TorsalFrameField, torsal_frame_field
from .remesh import ParametrizationError, TorsalParametrization, extract_quads, parametrize, remesh_torsal
from .support import (
    FinStrip,
    SupportOptimizationResult,
    SupportStructure,
    SupportWeights,
    fin_planarity,
    optimize_support,
)
from .torsal_curves import TorsalCurve, trace_torsal_curve

__all__ = [
    "Congruence", "FaceFrame", "MeshError", "load_mesh", "validate_mesh", "average_edge_length",
    "vertex_normals", "umbrella_laplacian", "boundary_vertices", "edge_face_adjacency",
    "SupportStructure", "FinStrip", "fin_planarity", "TorsalCurve", "trace_torsal_curve",
    "CongruenceProblem", "OptimizationResult", "OptimizationError",
    "torsal_frame_field", "TorsalFrameField", "FrameFieldError", "parametrize", "TorsalParametrization",
    "ParametrizationError", "extract_quads", "remesh_torsal", "optimize_support",
    "SupportOptimizationResult", "SupportWeights", "refine_developable",
]
