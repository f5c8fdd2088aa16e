"""Geometry: meshes, discrete line congruences, torsal curves, support structures."""
from torsal.core.lazy import lazy_exports
__getattr__, __dir__ = lazy_exports(__name__, {
    ".congruence": ("Congruence", "FaceFrame"),
    ".optimize": ("CongruenceProblem", "OptimizationError", "OptimizationResult"),
    ".mesh": ("MERGE_TOLERANCE", "MeshError", "MeshMerge", "average_edge_length",
              "boundary_vertices", "edge_face_adjacency", "load_mesh", "merge_vertices",
              "read_mesh_file", "umbrella_laplacian", "validate_mesh", "vertex_normals"),
    ".developable": ("refine_developable",),
    ".frame_field": ("FrameFieldError", "TorsalFrameField", "torsal_frame_field"),
    ".remesh": ("ParametrizationError", "TorsalParametrization", "extract_quads", "parametrize",
                "remesh_torsal"),
    ".support": ("FinStrip", "SupportOptimizationResult", "SupportStructure", "SupportWeights",
                 "fin_planarity", "optimize_support"),
    ".torsal_curves": ("TorsalCurve", "trace_torsal_curve"),
})

__all__ = [
    "Congruence", "FaceFrame", "MeshError", "MeshMerge", "MERGE_TOLERANCE", "merge_vertices",
    "read_mesh_file", "load_mesh", "validate_mesh", "average_edge_length",
    "vertex_normals", "umbrella_laplacian", "boundary_vertices", "edge_face_adjacency",
    "SupportStructure", "FinStrip", "fin_planarity", "TorsalCurve", "trace_torsal_curve",
    "CongruenceProblem", "OptimizationResult", "OptimizationError",
    "torsal_frame_field", "TorsalFrameField", "FrameFieldError", "parametrize", "TorsalParametrization",
    "ParametrizationError", "extract_quads", "remesh_torsal", "optimize_support",
    "SupportOptimizationResult", "SupportWeights", "refine_developable",
]
