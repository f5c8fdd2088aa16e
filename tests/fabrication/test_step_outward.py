"""A plate re-read from STEP stays the right way out (example 7c's F0-S001-P00 at 3db0016).

The STEP reader heals what it reads (ShapeFix_Solid), and orients a solid by classifying a
point at infinity; on this long (978 mm), thin (at most 127 mm across), non-convex plate that
classification comes out IN and the plate came back inside out: the assembly check's common of
it and the bracket at node 197 beside it was all of the bracket (4,314 mm^3), while the solids
as built are 0.05 mm apart. Rebuilt here from the two parts of that build (mm, moved near the
origin); seconds.
"""
import numpy as np

from torsal.fabrication.assembly.occ import _signed_volume, common_volume
from torsal.fabrication.exports import read_step, write_step
from torsal.fabrication.model import CONNECTOR_FAMILY, Part, PartId
from torsal.fabrication.plates import _part_shape

T = 3.0   # mm, the plates' and the connector's thickness in example 7c

PLATE = Part(
    id=PartId(0, 1, 0), nodes=np.array([197, 203]), edges=np.array([3]), span=(1, 2),
    panels=np.array([[[0.0, 0.0, 0.0], [511.746034, -94.268702, 274.933945],
                      [855.375307, -195.929554, 449.840339], [347.23544, -29.573109, 195.27731]]]),
    miters=np.array([[-0.492636386, -0.214172607, 0.843468723]] * 2))
BRACKET = Part(
    id=PartId(CONNECTOR_FAMILY, 197, 0), nodes=np.full(3, 197), edges=np.full(2, -1), span=(0, 2),
    panels=np.array([[[123.508808, -20.498352, 63.294383], [123.256096, -14.654087, 64.628812],
                      [227.426728, -23.526019, 123.212005], [227.67944, -29.370284, 121.877576]],
                     [[123.256096, -14.654087, 64.628812], [125.986204, -16.255817, 59.531659],
                      [230.156836, -25.127749, 118.114852], [227.426728, -23.526019, 123.212005]]]),
    miters=np.array([[0.49261143, 0.213909917, -0.843549955],
                     [0.562588201, -1.40438551, -1.213057513],
                     [-0.19338727, -0.960861371, 0.198360249]]))


def test_sliver_plate_reread_from_step_is_not_inside_out(tmp_path):
    built = {p.name: _part_shape(p, T) for p in (PLATE, BRACKET)}
    # as built: a sound plate, and the bracket clear of it
    assert _signed_volume(built[PLATE.name]) > 0
    assert common_volume(built[BRACKET.name], built[PLATE.name]) == 0.0
    path = tmp_path / "joint.step"
    write_step([(n, s, (0.5, 0.5, 0.5)) for n, s in built.items()], path, unit="mm")
    reread = dict(read_step(path))
    assert set(reread) == set(built)
    for name, solid in reread.items():
        v = _signed_volume(solid)
        # the volume of the plate as built (41,092 mm^3), and positive: not turned inside out
        assert v > 0 and abs(v - _signed_volume(built[name])) < 1e-6 * v, name
    # the bracket does not cut the plate re-read (was 4,314 mm^3: all of the bracket)
    assert common_volume(reread[BRACKET.name], reread[PLATE.name]) == 0.0
