"""The Rhino 3DM form of a solid part: a closed, valid Brep of its OCC solid with one planar
face per plane face of the solid, as openNURBS writes it into a .3dm file
(:func:`brep_record`, bytes that a worker process makes without rhino3dm), the rhino3dm
``Brep`` of those bytes (:func:`brep_of`), and a .3dm file written by rhino3dm with such
records put in the place of placeholder objects (:func:`splice_records`).

Why bytes: rhino3dm (8.x) has no way to join faces into a Brep but ``Brep.CreateFromMesh``,
which makes a face of every triangle or quad of the mesh (twice as many faces as the solids
have on example 7a, each a NURBS surface with NURBS trims) and leaves the edges' tolerance
unset (the Brep is not valid until its encoding is patched and decoded again); that, and
decoding and writing those Breps, cost 7.6-8.6 s of CPU on 7a's 314 parts, 1.1-1.2 s now
(``benchmarks/rhino_bench.py``, on a loaded machine). The record here is what openNURBS writes for an ``ON_Brep``
of ``ON_PlaneSurface`` faces trimmed by ``ON_LineCurve`` s (as rhino3dm's own
``Brep.CreateFromBox`` makes them), built with numpy from the solid's faces, checked to be
closed (every edge on two faces, in opposite senses) with outward faces; rhino3dm reads it as
a valid solid and writes it again byte for byte (the tests check both on every part).

The modules, in the order a record is made:

- :mod:`.faces`: the solid's meshed faces welded, each plane face as its boundary loops, a
  curved one as its triangles;
- :mod:`.topology`: the loops, trims, face planes, edges and vertices of those faces as numpy
  arrays, checked to close;
- :mod:`.records`: the topology as openNURBS bytes (curves, surfaces, tables, chunks, CRCs);
- :mod:`.brep`: the entry points (:func:`brep_record`, :func:`encoded_brep`, :func:`brep_of`;
  :func:`brep_volume` reads a Brep's volume back);
- :mod:`.mesh_brep`: rhino3dm's ``CreateFromMesh`` Brep, where the faces make no record;
- :mod:`.splice`: the records put into a file rhino3dm wrote (:func:`splice_records`);
- :mod:`.properties`: its file name and times made a function of the model (:func:`fixed_properties`).

Units: those of the solid.
"""
from __future__ import annotations

from .brep import _brep_bytes, _encoding, brep_of, brep_record, brep_volume, encoded_brep  # noqa: F401
from .faces import PLANAR, _membrane, _polygon_faces  # noqa: F401
from .mesh_brep import _mesh_brep, _quad, _rhino_mesh, _with_edge_tolerances  # noqa: F401
from .properties import fixed_properties
from .splice import placeholder, splice_records

__all__ = ["brep_of", "encoded_brep", "brep_record", "brep_volume", "splice_records", "fixed_properties"]
