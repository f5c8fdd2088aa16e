"""Geometry files of a design run: the congruence as PLY, support structures as OBJ."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..core.atomic import atomic_path
from ..geometry.congruence import Congruence

__all__ = ["write_geometry", "write_structure_obj", "target_patch"]


def target_patch(target, vertices, size: float | None = None):
    """A horizontal square around a reflection target (a patch of ceiling), as a trimesh;
    its side is a third of the surface's extent unless given."""
    import trimesh

    t = np.asarray(target, float)
    h = 0.5 * (size or np.ptp(vertices, axis=0).max() / 3.0)
    corners = t + np.array([[-h, -h, 0], [h, -h, 0], [h, h, 0], [-h, h, 0]])
    return trimesh.Trimesh(corners, [[0, 1, 2], [0, 2, 3]], process=False)


def write_geometry(out: Path, congruence: Congruence, structure) -> dict:
    """The optimized congruence as PLY (vertex directions as properties ex, ey, ez) and the
    support structure as OBJ (groups A, B and fins)."""
    v, f, e = congruence.vertices, congruence.faces, congruence.directions
    lines = ["ply", "format ascii 1.0", "comment torsal line congruence: lines a_i + t e_i",
             f"element vertex {len(v)}", "property double x", "property double y", "property double z",
             "property double ex", "property double ey", "property double ez",
             f"element face {len(f)}", "property list uchar int vertex_indices", "end_header"]
    lines += [" ".join(f"{x:.12g}" for x in row) for row in np.c_[v, e]]
    lines += [f"3 {a} {b} {c}" for a, b, c in f]
    with atomic_path(out / "congruence.ply") as tmp:
        tmp.write_text("\n".join(lines) + "\n")
    write_structure_obj(out / "support.obj", structure)
    return {"congruence": "congruence.ply", "support": "support.obj"}


def write_structure_obj(path: Path, s) -> None:
    """A support structure as OBJ: groups A (nodes on the surface), B, and the fins of
    each family (one quad per edge), each family's fins as deep as its own
    (``family_depth_ratio``: a family that stops short of B ends on vertices of its own,
    written after B's)."""
    n = len(s.vertices_a)
    obj = ["# torsal support structure: A~ (nodes on the surface), B~, one fin quad per edge"]
    ends = [s.vertices_a, s.vertices_b]
    offset = {}
    for fam in (0, 1):              # where each family's fins end: B, or a block of its own
        if s.family_depth_ratio[fam] == 1.0:
            offset[fam] = n
        else:
            offset[fam] = n * len(ends)
            ends.append(s.family_vertices_b(fam))
    obj += [f"v {x:.12g} {y:.12g} {z:.12g}" for block in ends for x, y, z in block]
    obj.append("g A")
    obj += ["f " + " ".join(str(i + 1) for i in poly) for poly in s.faces]
    obj.append("g B")
    obj += ["f " + " ".join(str(i + 1 + n) for i in poly) for poly in s.faces]
    for fam in (0, 1):
        obj.append(f"g fins_family_{fam}")
        k = offset[fam]
        for i, j in s.edges[s.edge_family == fam]:
            obj.append(f"f {i + 1} {j + 1} {j + 1 + k} {i + 1 + k}")
    with atomic_path(path) as tmp:
        tmp.write_text("\n".join(obj) + "\n")
