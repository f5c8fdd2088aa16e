"""Assembly verification: do the solids of a fin system interfere, and in which order can they
be put together? (issue 15)

The check reads only the finished solids (those the design's files are written from:
``FinSystem.solids()``, the solids' workers' copies of them,
:func:`~torsal.fabrication.workers.check_solids`, or the solids of a ``fins.step`` read with
:func:`~torsal.fabrication.solids.read_step`) and the joint records (part names and insertion
axes); it shares no code with the joint builder, so a mistake there shows up here.

1. **Touching pairs.** Axis-aligned bounding boxes grown by ``tolerance`` select candidate
   pairs; a proximity test on the solids' triangulations (``BRepExtrema_ShapeProximity``, a
   BVH of triangles; the triangulation of a planar face is exact) keeps the pairs whose
   boundaries come within ``tolerance``, and a point classification those where one solid
   lies inside the other: these are ``pairs_checked`` (:func:`solid_distance` gives the exact
   distance of a pair, ten times slower).
2. **Interference.** For every touching pair the common volume is computed with an exact
   OpenCascade boolean (``BRepAlgoAPI_Common``); a common volume above ``min_volume``
   (1 mm^3) is an interference. The booleans leave the solids unchanged (non-destructive:
   OpenCascade's default may change their tolerances, and then erred, and later booleans
   depended on what ran before in the process), and a common above 1 mm^3 is measured again
   in the other order and with a fuzzy tolerance, the median of the three counting
   (:func:`common_volume`; the swept paths of 3. alike). A
   boolean that fails is listed in ``failed_pairs`` and the
   design is not called buildable (nothing is assumed). Most touching plates only touch: a
   cheap exact test proves them apart first and skips the boolean (:func:`solid_clear`): one
   solid is covered by convex prisms (its exit faces swept back over its extent along its
   thinnest face normal, :func:`solid_cover`; a flat plate: its panels), and a prism is
   apart from the other solid when no triangle of the other's boundary reaches into it
   (separating axes, :func:`hull_clear_of_triangles`) and it is not wholly inside it (ray
   parity). Triangles may touch a prism or reach ``CLEAR_TOLERANCE`` (1e-7, OpenCascade's
   own confusion tolerance) into it. A pair the cover leaves undecided (a block in a slot's
   notch, a bent connector along a plate) is apart when every triangle of one boundary is
   more than that tolerance from every triangle of the other and neither solid holds the
   other (:func:`surfaces_clear`); only a pair still undecided gets the boolean (example 9:
   90 of 4,395 touching pairs, 734 before).
3. **Assembly order.** Parts are placed one by one in an order that follows the joints (the
   parts a joint lists first are placed first: for an egg-crate crossing the family-0
   plate(s), then the family-1 plate(s); for a butt joint the parts of the plate butted
   against, in any order among themselves, then the butted part; the two parts of a mitre in
   either order; connectors go on after the plates around them). Each part is inserted along a
   straight line: the axis of its joints with parts already placed (the joint's
   ``insert_direction``: for egg-crate pairs along the node axis ``L_i``, or the slide
   direction the builder cut the slots for; the mean axis of its slots first, then the mean of all its joints' axes,
   then each axis on its own, then the lines where two plates it butts against meet; both
   senses). The path starts one depth of the part back (``travel``: the part's extent
   along the direction, but no more than the largest ``depth`` of the joints it makes with
   parts placed before, the fin depth at their nodes, over which the parts engage: a slot is
   never longer; so it is disengaged from its slots) and ends in place; every placed part near the path is checked, joined or not. A
   path is clear when the volume swept by the part meets no placed part by more than
   ``min_volume``: the swept volume is the union of the prisms that every face of the solid
   sweeps (``BRepPrimAPI_MakePrism``), each intersected exactly with the placed parts near the
   path; the sum of those common volumes (an upper bound of the swept overlap) is the
   collision volume (a prism that :func:`prism_clear` or :func:`surfaces_clear` proves
   apart from a part adds 0 without the boolean). A part with no clear path is *blocked*.

A design is ``buildable`` when no pair interferes, no boolean failed and no part is blocked.

Pairs and paths are independent of one another; with ``workers > 1`` they are computed in
forked processes (each inherits the check, nothing is pickled).

The package, one job per module: :mod:`.result` (what the check finds), :mod:`.records` (the
joint records it reads, the placement order and the directions to try), :mod:`.occ` (the
OpenCascade kernels: booleans, distances, faces, triangles), :mod:`.separation` (the exact
cheap proofs that solids are apart), :mod:`.sweep` (the volume swept into placed parts),
:mod:`.checker` (:class:`AssemblyChecker`, the object that owns one check's solids and what is
made from them), :mod:`.workers` (its forked worker processes), :mod:`.memo` (what was
proved, by the solids' content: :class:`AssemblyMemo`) and :mod:`.load_path` (whether every
part, once in, is held to the building through bolts, anchors and slots: :func:`load_path`).

Units: those of the solids (``unit`` of the fin system, mm by default): volumes in unit^3.

Example
-------
>>> from torsal.fabrication import FinSystem, verify_assembly
>>> fs = FinSystem(structure, thickness=3.0, clearance=0.5)              # doctest: +SKIP
>>> check = verify_assembly(fs)                                          # doctest: +SKIP
>>> check.buildable, check.pairs_checked, check.worst_overlap_mm3        # doctest: +SKIP
(True, 12, 0.0)
>>> check.write_csv("out/assembly.csv")                                  # doctest: +SKIP
"""
from torsal.core.lazy import lazy_exports
from .load_path import (BUILDING, Fastening, LoadPath, check_load_path, fastenings_of,
                        load_path)
__getattr__, __dir__ = lazy_exports(__name__, {
    ".checker": ("AssemblyChecker", "check_assembly", "verify_assembly"),
    ".memo": ("AssemblyMemo", "solid_digest"),
    ".occ": ("_bbox", "_boolean_common", "_boundary_triangles", "_face_prism", "_face_records",
             "_mesh", "_volume", "common_volume", "face_polygons", "solid_distance"),
    ".records": ("AssemblyJoint", "joint_groups", "joints_of"),
    ".result": ("MIN_INTERFERENCE_VOLUME", "TOUCHING_TOLERANCE", "AssemblyCheck", "AssemblyStep",
                "Interference"),
    ".separation": ("CLEAR_TOLERANCE", "_inside_by_ray", "hull_clear_of_triangles",
                    "prism_clear", "prisms_clear", "solid_clear", "solid_cover",
                    "surfaces_clear"),
    ".sweep": ("swept_overlap",),
})

__all__ = ["Interference", "AssemblyStep", "AssemblyCheck", "AssemblyJoint", "AssemblyChecker",
           "check_assembly", "verify_assembly", "joints_of", "face_polygons", "common_volume",
           "solid_distance", "swept_overlap", "joint_groups", "MIN_INTERFERENCE_VOLUME",
           "TOUCHING_TOLERANCE",
           "CLEAR_TOLERANCE", "hull_clear_of_triangles", "prism_clear", "prisms_clear",
           "solid_cover", "solid_clear", "surfaces_clear", "AssemblyMemo", "solid_digest",
           "BUILDING", "Fastening", "LoadPath", "check_load_path", "fastenings_of", "load_path"]
