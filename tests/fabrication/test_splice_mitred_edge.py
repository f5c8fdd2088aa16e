"""A splice plate on the convex side of a seam clears the mitred edge of a plate that folds
there (example 9 at 3db0016: C-N0202-0 and F0-S042-P00).

At node 202 the family-1 part F1-S047-P06 ends where panel 4 of the family-0 plate
F0-S042-P00 carries its fin on (12 degrees off flat), and the splice plate goes round the
outside of that seam. F0-S042-P00 itself folds 51 degrees at that node line (its panel 3 goes
off on the other side), so its face under the splice ends in a mitred edge standing 0.72 mm
past the node line, under the splice's other leg: the splice, laid 0.03 mm off both plates'
faces, cut the plate's edge along its whole length (2.03 mm^3, "not buildable"). Rebuilt here
from the parts of that build (mm, moved near the origin): panels 3-4 of the plate, the end
panel of F1-S047-P06, and the splice placed as the joint builder places it; seconds.
"""
import numpy as np
import pytest

from torsal.fabrication.builder.ends import CONNECTOR_GAP, seam_splice
from torsal.fabrication.joints import connector_offset
from torsal.fabrication.model import CONNECTOR_FAMILY, Part, PartId, _miter, quad_normals
from torsal.fabrication.plates import _part_shape

from torsal.fabrication.assembly.occ import solid_distance

from occ_overlap import common_volume

T = 3.0   # mm, the sheet of example 9

PLATE = Part(     # F0-S042-P00, panels 3 and 4 (nodes 396, 202, 414)
    id=PartId(0, 42, 0), nodes=np.array([396, 202, 414]), edges=np.array([188, 204]), span=(3, 5),
    panels=np.array([[[-492.771938, -349.961948, -17.741729], [-0.000457, 0.000140, -0.000182],
                      [-56.813051, 277.294516, 194.972890], [-650.263500, -119.808899, 188.902932]],
                     [[-0.000457, 0.000140, -0.000182], [392.384218, -276.502202, 78.644798],
                      [257.161120, 7.448290, 215.518621], [-56.813051, 277.294516, 194.972890]]]),
    miters=np.array([[0.251381, -0.548456, 0.802468], [-0.121570, -0.650726, 0.889991],
                     [-0.139787, -0.536345, 0.974626]]))
END = Part(       # F1-S047-P06: its end panel, trimmed back from the seam at node 202
    id=PartId(1, 47, 6), nodes=np.array([200, 202]), edges=np.array([661]), span=(10, 11),
    panels=np.array([[[-324.833981, 109.077617, -62.306858], [-4.346524, 1.459527, -0.833806],
                      [-60.995578, 278.412285, 193.943403], [-469.062350, 387.466978, 93.501893]]]),
    miters=np.array([[-1.865938, -0.862598, -0.186080], [-0.435204, -0.579324, 0.697119]]))
A, B = PLATE.panels[1, 0], PLATE.panels[1, 3]          # node line 202
TOWARDS = np.array([0.338037, 0.586787, -0.735807])    # the side of the seam the splice is on


def _splice():
    q, opt = seam_splice(END, 0, PLATE, 1, A, B, TOWARDS, thickness=T, gap=CONNECTOR_GAP * T)
    n = quad_normals(q)
    return Part(id=PartId(CONNECTOR_FAMILY, 202, 0), panels=q, nodes=np.full(3, 202),
                edges=np.full(2, -1), miters=np.array([n[0], _miter(n[0], n[1]), n[1]]),
                span=(0, 2)), opt


def test_splice_clears_the_mitred_edge_of_the_folding_plate():
    splice, opt = _splice()
    # the plate folds 51 deg at the node line: its face on the splice's side ends in an edge
    # t/2 tan(25.6 deg) = 0.72 mm past the line
    n3, n4 = PLATE.normals
    assert np.degrees(np.arccos(n3 @ n4)) == pytest.approx(51.3, abs=0.1)
    solids = {p.name: _part_shape(p, T) for p in (PLATE, END, splice)}
    assert common_volume(solids[splice.name], solids[PLATE.name]) == 0.0    # was 2.03 mm^3
    assert common_volume(solids[splice.name], solids[END.name]) == 0.0
    # measured on the solids as built (OpenCascade's distance): the splice is the gap
    # (0.03 mm) off the plate, up to the panels' warp, and touches it (was 2.03 mm^3 inside)
    gap = CONNECTOR_GAP * T
    assert gap - 1e-6 <= solid_distance(solids[splice.name], solids[PLATE.name]) <= gap + 0.05
    # its legs lie on both plates, the leg on the end 0.17 mm off its face at most (a bolt
    # pulls that tight)
    for k, (part, j) in enumerate(((END, 0), (PLATE, 1))):
        n = opt[k][0]
        face = part.panels[j].mean(axis=0) + 0.5 * T * n
        leg = splice.panels[k].mean(axis=0) - 0.5 * T * n
        assert gap - 1e-6 <= (leg - face) @ n <= 0.2


def test_a_splice_on_the_concave_side_is_not_moved():
    # the same seam seen from the other side: each leg has only its own plate under it
    (n1, v1), (n2, v2) = _splice()[1][:2]
    plates = (END.slab_corners(0, T), PLATE.slab_corners(1, T))
    assert connector_offset(A, B, (-n1, v1), (-n2, v2), 3.09, plates, thickness=T, gap=0.09) == 3.09
    # on the convex side it moves out by what the plate's mitred edge stands out under the leg
    # on the end: t/2 tan(25.6 deg) = 0.72 mm past the line, times the sine of the 12 deg
    # between the two: about 0.15 mm (and the panels' warp)
    assert 3.09 + 0.1 < connector_offset(A, B, (n1, v1), (n2, v2), 3.09, plates, thickness=T,
                                         gap=0.09) < 3.09 + 0.25
