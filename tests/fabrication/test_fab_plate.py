"""The plate kernel of the solids (``solids._plate_direct``: a part's thickened panels as one
B-rep shell built directly, no sewing) against volumes computed by hand, and against the
sewn construction it replaces."""
from __future__ import annotations

import numpy as np
import pytest

from torsal.fabrication.model import Part, PartId

pytest.importorskip("OCP")
from torsal.fabrication import solids  # noqa: E402


def _volume_valid(shape):
    return solids._volume(shape), solids._is_valid(shape)


def _part(panels, miters):
    panels = np.asarray(panels, float)
    k = len(panels)
    return Part(PartId(0, 0, 0), panels, np.full(k + 1, -1), np.full(k, -1),
                miters=np.asarray(miters, float))


def test_flat_rectangle_is_a_box_of_area_times_thickness():
    w, h, t = 300.0, 150.0, 3.0
    part = _part([[[0, 0, 0], [w, 0, 0], [w, h, 0], [0, h, 0]]], [[0, 0, 1], [0, 0, 1]])
    shape, poly = solids._plate_direct(part, t, 1e-9)
    vol, ok = _volume_valid(shape)
    assert ok
    assert abs(vol) == pytest.approx(w * h * t, rel=1e-12)
    assert abs(poly) == pytest.approx(w * h * t, rel=1e-12)


@pytest.mark.parametrize("fold_deg", [30.0, 90.0, 135.0])
def test_mitred_fold_keeps_area_times_thickness(fold_deg):
    """Two 200 x 100 panels folded by ``fold_deg`` about the y axis, offset along the mitre
    vector (m.n = 1 on both sides): the wedge gained outside the fold is the one lost inside,
    so the volume is exactly 2 * 200 * 100 * t."""
    a, t, h = 200.0, 4.0, 100.0
    phi = np.radians(fold_deg)
    d = np.array([np.cos(phi), 0.0, np.sin(phi)])               # second panel's direction
    p0, p1, p2 = np.zeros(3), np.array([a, 0, 0]), np.array([a, 0, 0]) + a * d
    y = np.array([0, h, 0])
    panels = [[p0, p1, p1 + y, p0 + y], [p1, p2, p2 + y, p1 + y]]
    n1, n2 = np.array([0.0, 0, 1]), np.cross(y, d) / h          # unit normals of the panels
    n2 *= np.sign(n2 @ np.cross(panels[1][1] - panels[1][0], panels[1][3] - panels[1][0]))
    n1 *= np.sign(n1 @ np.cross(p1 - p0, y))
    m = (n1 + n2) / (1 + n1 @ n2)
    shape, _ = solids._plate_direct(_part(panels, [n1, m, n2]), t, 1e-9)
    vol, ok = _volume_valid(shape)
    assert ok
    assert abs(vol) == pytest.approx(2 * a * h * t, rel=1e-9)


def test_triangular_panel_with_a_collapsed_corner():
    """A quad whose last two corners coincide (a triangle, legs 120 and 80): the side face
    there collapses to an edge; volume = 120 * 80 / 2 * t."""
    t = 3.0
    q = [[0, 0, 0], [120, 0, 0], [0, 80, 0], [0, 80, 0]]
    shape, poly = solids._plate_direct(_part([q], [[0, 0, 1], [0, 0, 1]]), t, 1e-9)
    vol, ok = _volume_valid(shape)
    assert ok
    assert abs(vol) == pytest.approx(0.5 * 120 * 80 * t, rel=1e-12)
    assert abs(poly) == pytest.approx(abs(vol), rel=1e-12)


def test_warped_panel_is_split_like_the_sewn_plate():
    """A quad lifted at one corner by 0.5 (not planar): top and bottom are split into two
    triangles on the same diagonal; volume = (area of the two triangles) * t, as the sewn
    construction gives it."""
    t = 3.0
    q = np.array([[0, 0, 0], [100, 0, 0], [100, 100, 0.5], [0, 100, 0]], float)
    part = _part([q], [[0, 0, 1], [0, 0, 1]])
    shape, poly = solids._plate_direct(part, t, 1e-9)
    vol, ok = _volume_valid(shape)
    assert ok
    # top and bottom are the same two triangles (0 1 2, 0 2 3) shifted by t along z: the
    # prism between them has the volume of their projection on xy times t
    assert abs(vol) == pytest.approx(100 * 100 * t, rel=1e-9)
    sewn, _ = solids._plate_sewn(part, t, 1e-9)
    assert abs(vol) == pytest.approx(abs(solids._volume(sewn)), rel=1e-9)


def test_corners_closer_than_the_sewing_tolerance_are_sewn():
    """Corners 1e-8 apart are one point to the sewing; the direct construction declines them
    (ValueError) and ``_plate`` falls back to sewing: still a solid of area * thickness."""
    t = 3.0
    q = [[0, 0, 0], [120, 0, 0], [0, 80, 0], [0, 80 + 1e-8, 0]]
    part = _part([q], [[0, 0, 1], [0, 0, 1]])
    with pytest.raises(ValueError):
        solids._plate_direct(part, t, 1e-9)
    shape, _ = solids._plate(part, t, 1e-9)
    assert abs(solids._volume(shape)) == pytest.approx(0.5 * 120 * 80 * t, rel=1e-6)


def _oblique_slotted_part():
    """Example 7c's F1-S014-P00 (3 mm; see the test below) and its slot's depth and width."""
    from torsal.fabrication.model import Slot, SlotSide

    panels = np.array([[[-5999.83052476, 13.31229996, 3477.24277357],
                        [-5864.20972631, -26.21847629, 3547.10035039],
                        [-5538.06077526, -236.55972021, 3638.59236808],
                        [-5668.42544892, -185.68370608, 3580.0498467]],
                       [[-5864.20972631, -26.21847629, 3547.10035039],
                        [-5284.69432097, -195.33325482, 3811.3439849],
                        [-5090.50233024, -538.24742652, 3757.7441048],
                        [-5538.06077526, -236.55972021, 3638.59236808]]])
    miters = np.array([[0.50824604, 0.47565775, -0.71793849],
                       [0.49272643, 0.43513779, -0.75577099],
                       [0.55841155, 0.42875937, -0.71946299]])
    depth, width = 199.3660994649929, 5.163270815622281
    part = Part(PartId(1, 14, 0), panels, np.array([6, 205, 208]), np.array([466, 270]),
                slots=[Slot(node=205, position=1, side=SlotSide.B, depth=depth, width=width,
                            partner="F0-S001-P00")], miters=miters)
    return part, depth, width


def test_slot_in_a_thin_oblique_plate_is_cut():
    """Example 7c's F1-S014-P00 (3 mm, two panels met obliquely by a 5.2 mm slot 199 mm deep):
    OpenCascade's exact boolean returned an empty shape and the part was modelled without its
    slot, so the assembly check found it blocked by its egg-crate partner. The fuzzy retry
    (``SLOT_CUT_FUZZY``) cuts it: the slot is open, measured independently with a point
    classifier at the slot's middle, and slot area x thickness is removed."""
    from OCP.BRepClass3d import BRepClass3d_SolidClassifier
    from OCP.gp import gp_Pnt
    from OCP.TopAbs import TopAbs_IN, TopAbs_OUT

    from torsal.fabrication.plates import _part_shape

    part, depth, width = _oblique_slotted_part()
    panels, t = part.panels, 3.0
    shape = _part_shape(part, t)
    # the slot runs from the node line's B end (panels[0, 2]) towards its A end (panels[0, 1]),
    # centred on the node line: probe the mid-plane across the slot and along it
    b, a = panels[0, 2], panels[0, 1]
    length = np.linalg.norm(a - b)
    u = (a - b) / length
    cls = BRepClass3d_SolidClassifier(shape)

    def state(along, across, panel):
        into = panels[panel].mean(axis=0) - b
        into -= (into @ u) * u
        x = b + along * u + across * into / np.linalg.norm(into)
        cls.Perform(gp_Pnt(*map(float, x)), 1e-6)
        return cls.State()

    for panel in (0, 1):
        # (near the mouth panel 0 narrows to a sliver: its edge leaves the node line at 15 deg)
        for along in np.linspace(0.25, 0.95, 6) * depth:    # open along its depth
            assert state(along, 0.4 * width, panel) == TopAbs_OUT
            assert state(along, 0.75 * width, panel) == TopAbs_IN     # and no wider
        # the web beyond the slot is kept
        assert state(depth + 0.5 * (length - depth), 0.4 * width, panel) == TopAbs_IN


def test_oblique_slotted_plate_is_a_solid_brep_in_3dm(tmp_path):
    """The fuzzy cut of that plate leaves a membrane of zero thickness (coincident faces of
    opposite orientation) inside the OCC solid; fins.3dm drops it and writes the part as a
    closed Brep (rhino3dm made none before: the part went into fins.3dm as a mesh). Re-read
    from the file: a valid solid around the plate's panels."""
    rhino3dm = pytest.importorskip("rhino3dm")
    from torsal.fabrication.exports import brep_of
    from torsal.fabrication.plates import _part_shape

    part, _, _ = _oblique_slotted_part()
    shape = _part_shape(part, 3.0)
    model = rhino3dm.File3dm()
    model.Objects.AddBrep(brep_of(shape, 0.15))
    assert model.Write(str(tmp_path / "part.3dm"), 7)
    brep = rhino3dm.File3dm.Read(str(tmp_path / "part.3dm")).Objects[0].Geometry
    assert isinstance(brep, rhino3dm.Brep) and brep.IsSolid and brep.IsValid
    # its vertices span the plate: its panels' box, widened by at most the thickness
    v = np.array([[x.Location.X, x.Location.Y, x.Location.Z] for x in brep.Vertices])
    pts = part.panels.reshape(-1, 3)
    assert np.all(np.abs(v.min(axis=0) - pts.min(axis=0)) < 3.0)
    assert np.all(np.abs(v.max(axis=0) - pts.max(axis=0)) < 3.0)


_FORKED_SHAPE = None


def _triangles_in_child(q):
    from torsal.fabrication.assembly.occ import _boundary_triangles
    q.put(len(_boundary_triangles(_FORKED_SHAPE)))


def test_forked_assembly_worker_meshes_after_a_threaded_mesh_in_the_parent():
    """The assembly check's forked workers triangulate solids whose mesh is incomplete (the
    oblique slotted plate above: its membrane faces do not mesh at the check's deflection).
    After the parent has meshed in parallel (the 3DM export does), OpenCascade's thread
    pool has no threads in the child: a parallel mesh there waited for ever (7c's assembly
    stage hung). The workers mesh serially; the child ends with the plate's triangles."""
    import multiprocessing

    from build123d import Box, Cylinder

    from torsal.fabrication.plates import _mesh, _part_shape

    if "fork" not in multiprocessing.get_all_start_methods():
        pytest.skip("no fork on this platform: the assembly check runs its jobs in-process")
    global _FORKED_SHAPE
    part, _, _ = _oblique_slotted_part()
    _FORKED_SHAPE = _part_shape(part, 3.0)
    _mesh((Box(5, 5, 5) - Cylinder(1, 20)).wrapped, 0.01)       # the parent's thread pool
    ctx = multiprocessing.get_context("fork")
    q = ctx.Queue()
    child = ctx.Process(target=_triangles_in_child, args=(q,))
    child.start()
    child.join(60)
    hung = child.is_alive()
    if hung:
        child.kill()
    assert not hung
    assert q.get(timeout=5) > 20


def test_a_slot_wider_than_the_narrow_end_panel_next_to_it_is_cut():
    """Example 9's F0-S001-P00 at node 335: a 23 mm slot on the node line before a 5.6 mm end
    panel takes all of that panel down to its depth. The check that the web beyond the slot
    is kept probed a quarter of the slot's width into the narrow panel, outside the plate, so
    the part was modelled without its slots and met its partners. Now it probes in the wider
    panel: the slotted solid is kept, and the volume taken out is the slot's band over both
    panels (measured by hand: flat panels, slot square to the sheet)."""
    from torsal.fabrication.model import Slot, SlotSide
    from torsal.fabrication.plates import _part_shape

    t, depth, width, h = 3.0, 100.0, 23.0, 200.0
    xs = [0.0, 150.0, 155.6]              # a 150 mm panel, then a 5.6 mm one
    panels = np.array([[[x0, 0, 0], [x1, 0, 0], [x1, h, 0], [x0, h, 0]]
                       for x0, x1 in zip(xs[:-1], xs[1:])])
    part = Part(PartId(0, 1, 0), panels, np.array([5, 335, 28]), np.array([0, 1]),
                slots=[Slot(node=335, position=1, side=SlotSide.A, depth=depth, width=width)],
                miters=np.tile([0.0, 0.0, 1.0], (3, 1)))
    shape = _part_shape(part, t)
    # the slot band: 11.5 mm of the wide panel and all 5.6 mm of the narrow one, 100 mm deep
    removed = (0.5 * width + (xs[2] - xs[1])) * depth * t
    assert solids._volume(shape) == pytest.approx((xs[2] * h) * t - removed, rel=1e-9)
