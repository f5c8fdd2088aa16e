"""IFC4 export of a fin system: the fins as building elements a BIM tool reads (issue 43).

:func:`export_ifc` writes one IFC4 file (through ifcopenshell) that holds

* the spatial structure: project, site (latitude, longitude, elevation and true north when
  given), building and one storey, the fins' elevation 0;
* every part of ``parts.csv`` as one element named as there (and in the DXF and STEP): the fin
  plates, connectors (brackets, splice plates) and fixings as ``IfcPlate`` (fins
  ``SHEET``; connectors and fixings ``USERDEFINED`` with the joint kind as ``ObjectType``);
* every strip of plates as an ``IfcElementAssembly`` that aggregates its parts (named like
  the part-id prefix, ``F0-S003``); connectors, fixings and fasteners are in the storey;
* every bolt and anchor as an ``IfcMechanicalFastener`` (``BOLT``, ``ANCHORBOLT``) with its
  nominal diameter and length, drawn as a cylinder through the plies it holds;
* the material: an ``IfcMaterialLayerSet`` of one layer ``thickness`` thick, with its mass
  density, used by every plate (an ``IfcMaterialLayerSetUsage`` along the extrusion of a flat
  plate); a second material for the fasteners;
* torsal's data per element in property sets ``Torsal_Part`` (part name, family, strip,
  panel index, joint kind, joints, panels, holes, fastener, body), ``Torsal_Strip`` and
  ``Torsal_Fastener``, and ``Pset_PlateCommon`` (``Reference`` = part name, external, not
  load bearing). The custom sets do not start with ``Pset_``: buildingSMART reserves that
  prefix for its own sets, and the validation service rejects unknown ones.

Geometry (:class:`PlateBody`): a part whose solid is a right prism (a flat plate: every face
on its two faces' planes or square to them) is an ``IfcExtrudedAreaSolid`` of its outline
(slots included) with its fastener holes as inner circles; any other part (folded strips,
bent connectors and fixings, flat plates with a mitred or butt-trimmed end) is an
``IfcTriangulatedFaceSet`` of its STEP solid with ``Closed`` set. Both are made from the
solids of ``fins.step`` (:func:`~.workers.solid_shapes`), so every element has the volume of
the same part there, less its drilled holes where they are drawn (a flat plate's); the bent
parts are the STEP's nominal solids, without holes.

Units: the fin system's ``unit`` (mm by default) is the project's length unit; areas in m^2,
volumes in m^3, mass density kg/m^3. Element coordinates are the fin system's model frame
(``+z`` up, true north ``north_angle`` degrees counter-clockwise from ``+y``).

Example
-------
>>> from torsal.fabrication.ifc import export_ifc
>>> export_ifc(fs, "fins.ifc", latitude=48.21, longitude=16.37)     # doctest: +SKIP
PosixPath('fins.ifc')
"""
from __future__ import annotations

import uuid
from dataclasses import dataclass
from enum import Enum
from pathlib import Path

import numpy as np

from torsal.core.atomic import atomic_path
from torsal.core.units import UNIT_TO_MM

from .exports import _time_stamp
from .builder.fasteners import Fastener, anchor_for, fastener_for, part_fastening
from .model import CONNECTOR_FAMILY, FIXING_FAMILY, Part, PartId, quad_normals
from .plates import MESH_TOLERANCE, _triangles
from .workers import solid_shapes

__all__ = ["export_ifc", "PlateBody", "FastenerPlacement", "fastener_placements",
           "prism_profile", "closed_triangles", "BOLT_PROTRUSION", "ANCHOR_EMBEDMENT"]

#: a bolt is drawn this many bolt diameters longer than its grip (the nut and the thread
#: standing out of it)
BOLT_PROTRUSION = 1.0
#: an anchor is drawn from the fixing's outer face into the building, this many anchor
#: diameters deeper than the fixing (a usual embedment depth of bonded and expansion anchors)
ANCHOR_EMBEDMENT = 8.0
#: radians: a face lies on (or square to) a plate's plane within this angle
_ANGLE_TOL = 1e-7
#: IFC names of the metric units torsal knows: (SI prefix, None) or (None, conversion name)
_LENGTH_UNITS = {"mm": ("MILLI", None), "cm": ("CENTI", None), "m": (None, None),
                 "in": (None, "inch"), "ft": (None, "foot")}
_FASTENER_TYPES = {"bolt": "BOLT", "anchor": "ANCHORBOLT"}


class PlateBody(str, Enum):
    """How an element's body is written."""

    #: ``IfcExtrudedAreaSolid`` of the plate's outline (a flat plate, square edges)
    EXTRUSION = "extrusion"
    #: ``IfcTriangulatedFaceSet`` (``Closed``) of the part's solid (folded, bent, mitred)
    TRIANGULATED = "triangulated"


# ------------------------------------------------------------------ geometry of the parts
@dataclass(frozen=True)
class _Profile:
    """A right prism: ``outer`` (n, 2) and ``inner`` loops (each (m, 2)) in the frame
    ``origin, x_dir, z_dir`` (3-vectors; the loops lie in its xy plane) extruded ``depth``
    along ``+z``."""

    origin: np.ndarray
    x_dir: np.ndarray
    z_dir: np.ndarray
    outer: np.ndarray
    inner: tuple
    depth: float

    def local(self, points) -> np.ndarray:
        """Points (k, 3) of the model frame in the profile's plane coordinates (k, 2)."""
        y = np.cross(self.z_dir, self.x_dir)
        d = np.asarray(points, float).reshape(-1, 3) - self.origin
        return np.c_[d @ self.x_dir, d @ y]


def _planar_faces(shape) -> list | None:
    """``[(face, outward unit normal (3,))]`` of an OCC solid; None if any face is not planar."""
    from OCP.BRepAdaptor import BRepAdaptor_Surface
    from OCP.GeomAbs import GeomAbs_Plane
    from OCP.TopAbs import TopAbs_FACE, TopAbs_REVERSED
    from OCP.TopExp import TopExp_Explorer
    from OCP.TopoDS import TopoDS

    out, exp = [], TopExp_Explorer(shape, TopAbs_FACE)
    while exp.More():
        face = TopoDS.Face(exp.Current())
        surf = BRepAdaptor_Surface(face)
        if surf.GetType() != GeomAbs_Plane:
            return None
        d = surf.Plane().Axis().Direction()
        n = np.array([d.X(), d.Y(), d.Z()])
        out.append((face, -n if face.Orientation() == TopAbs_REVERSED else n))
        exp.Next()
    return out


def _area(face) -> float:
    """Area of an OCC face."""
    from OCP.BRepGProp import BRepGProp
    from OCP.GProp import GProp_GProps

    props = GProp_GProps()
    BRepGProp.SurfaceProperties_s(face, props)
    return float(props.Mass())


def _loop(wire, face) -> np.ndarray | None:
    """Ordered corners (n, 3) of a wire of straight edges; None if an edge is curved."""
    from OCP.BRep import BRep_Tool
    from OCP.BRepAdaptor import BRepAdaptor_Curve
    from OCP.BRepTools import BRepTools_WireExplorer
    from OCP.GeomAbs import GeomAbs_Line

    pts, we = [], BRepTools_WireExplorer(wire, face)
    while we.More():
        if BRepAdaptor_Curve(we.Current()).GetType() != GeomAbs_Line:
            return None
        p = BRep_Tool.Pnt_s(we.CurrentVertex())
        pts.append((p.X(), p.Y(), p.Z()))
        we.Next()
    return np.array(pts, float).reshape(-1, 3)


def prism_profile(shape, thickness: float) -> _Profile | None:
    """The outline of a flat plate's solid, or None if the solid is not a right prism.

    Parameters
    ----------
    shape : OCC solid
        A part's solid (as in fins.step), in the fin system's ``unit``.
    thickness : float
        Plate thickness (``unit``): the prism's height must be this (relative 1e-6).

    Returns
    -------
    _Profile or None
        Coplanar faces are merged first (a flat strip of several panels); the profile is the
        plate's bottom face (outline and any inner loops), extruded by ``thickness`` along
        the plate's normal (that of its largest face). None where a face is curved or
        neither on the plate's planes nor square to them (a mitred or butt-trimmed end, a
        fold).
    """
    from OCP.BRepTools import BRepTools
    from OCP.ShapeUpgrade import ShapeUpgrade_UnifySameDomain
    from OCP.TopAbs import TopAbs_WIRE
    from OCP.TopExp import TopExp_Explorer
    from OCP.TopoDS import TopoDS

    unify = ShapeUpgrade_UnifySameDomain(shape, True, True, False)
    unify.Build()
    faces = _planar_faces(unify.Shape())
    if not faces:
        return None
    z = max(faces, key=lambda fn: _area(fn[0]))[1]         # a plate's largest face: a cap
    caps = [(f, n) for f, n in faces if abs(abs(n @ z) - 1.0) <= _ANGLE_TOL]
    square = all(abs(n @ z) <= _ANGLE_TOL for f, n in faces if abs(abs(n @ z) - 1.0) > _ANGLE_TOL)
    if len(caps) != 2 or not square:
        return None
    bottom = next(f for f, n in caps if n @ z < 0)       # outward normal -z: the base
    outer_wire = BRepTools.OuterWire_s(bottom)
    outer = _loop(outer_wire, bottom)
    inner, exp = [], TopExp_Explorer(bottom, TopAbs_WIRE)
    while exp.More():
        wire = TopoDS.Wire(exp.Current())
        if not wire.IsSame(outer_wire):
            inner.append(_loop(wire, bottom))
        exp.Next()
    top = next(f for f, n in caps if n @ z > 0)
    top_loop = _loop(BRepTools.OuterWire_s(top), top)
    if outer is None or top_loop is None or any(r is None for r in inner) or len(outer) < 3:
        return None
    depth = float((top_loop[0] - outer[0]) @ z)
    if not abs(depth - thickness) <= 1e-6 * thickness:
        return None
    x = outer[1] - outer[0]
    x = x - (x @ z) * z
    prof = _Profile(outer[0], x / np.linalg.norm(x), z, np.zeros((0, 2)), (), depth)
    return _Profile(prof.origin, prof.x_dir, z, prof.local(outer),
                    tuple(prof.local(r) for r in inner), depth)


def closed_triangles(shape, tolerance: float) -> tuple[np.ndarray, np.ndarray, bool]:
    """A closed triangle mesh of an OCC solid: its faces' triangles with shared vertices.

    Parameters
    ----------
    shape : OCC solid
    tolerance : float
        Deflection of curved faces (``unit``); plane faces are exact.

    Returns
    -------
    vertices : (n, 3) float
    triangles : (m, 3) int
        Indices into ``vertices``, facing out; triangles with a repeated corner left out.
    closed : bool
        Every edge is shared by exactly two triangles, in opposite senses (a closed,
        oriented surface: IFC's ``Closed``).
    """
    v, f = _triangles(shape, tolerance)
    vertices, inverse = np.unique(v, axis=0, return_inverse=True)
    tri = inverse.reshape(-1)[f]
    tri = tri[(tri[:, 0] != tri[:, 1]) & (tri[:, 1] != tri[:, 2]) & (tri[:, 2] != tri[:, 0])]
    a, b = tri.ravel(), np.roll(tri, -1, axis=1).ravel()
    n = len(vertices)
    directed = a.astype(np.int64) * n + b
    keys, counts = np.unique(directed, return_counts=True)
    closed = bool(len(tri) and (counts == 1).all()
                  and np.isin(b.astype(np.int64) * n + a, keys).all())
    return vertices, tri, closed


# ------------------------------------------------------------------ the fasteners
@dataclass(frozen=True)
class FastenerPlacement:
    """One bolt or anchor of a fin system.

    Attributes
    ----------
    fastener : Fastener
        Size and kind (``bolt``, ``anchor``), diameters in mm.
    part : str
        The connector or fixing whose hole it goes through.
    hole : int
        Index of that hole in ``Part.holes``.
    host : str
        The fin plate it holds the part to (``""`` for an anchor: the building).
    start : (3,) float
        Where its shank starts, on the part's outer face (``unit``, model frame).
    direction : (3,) float
        Unit vector along the shank, into the plies (into the building for an anchor).
    length : float
        Drawn length (``unit``): the grip (the plies it passes) plus
        :data:`BOLT_PROTRUSION` diameters for a bolt; the fixing and
        :data:`ANCHOR_EMBEDMENT` diameters for an anchor.
    """

    fastener: Fastener
    part: str
    hole: int
    host: str
    start: np.ndarray
    direction: np.ndarray
    length: float


def _plate_holes(fs) -> tuple[np.ndarray, list[str]]:
    """Centres (k, 3) of the fin plates' holes and the plate of each (the matching holes: not
    those of a tab bent from the plate, whose bolt goes through them from the tab)."""
    centres, hosts = [], []
    for p in fs.plates:
        for h in p.holes:
            if getattr(h, "own", False):
                continue
            centres.append(h.center)
            hosts.append(p.name)
    return np.asarray(centres, float).reshape(-1, 3), hosts


def fastener_placements(fs) -> list[FastenerPlacement]:
    """Every bolt and anchor of a finished fin system, one per hole of a connector, fixing or
    tab bent from a fin plate that is not shared (a bolt through two connectors on the two
    faces of a plate is placed once, at the first, with a grip of three plates): as many as the
    ``fasteners`` column of parts.csv counts.

    The bolt runs from the part's outer face through the part and the fin plate it lies on
    (the plate's matching hole, the nearest plate hole within ``2 thickness``); an anchor
    from the fixing's outer face into the building (away from the fixing's other leg).

    >>> sum(p.fastener.kind == "bolt" for p in fastener_placements(fs))   # doctest: +SKIP
    48
    """
    from scipy.spatial import cKDTree

    t, mm = fs.thickness, UNIT_TO_MM[fs.unit]
    sizes = {f.label: f for f in (fastener_for(t * mm), anchor_for(t * mm))}
    centres, hosts = _plate_holes(fs)
    plate_tree = cKDTree(centres) if len(centres) else None
    shared = [h.center for p in fs.parts for h in p.holes if h.shared]
    shared_tree = cKDTree(np.asarray(shared, float).reshape(-1, 3)) if shared else None
    out = []
    # (the tabs' holes are their plates' own: a bolt through the tab and the plate it lies on)
    tabbed = [p for p in fs.plates if any(getattr(h, "own", False) for h in p.holes)]
    for p in fs.connectors + fs.fixings + tabbed:
        normals = quad_normals(p.panels)
        loose = p.family in (CONNECTOR_FAMILY, FIXING_FAMILY)
        for i, h in enumerate(p.holes):
            if h.shared or not (loose or getattr(h, "own", False)):
                continue
            f = sizes[h.fastener]
            d = f.bolt_mm / mm
            n = normals[h.panel]
            if f.kind == "anchor":
                other = p.panels[1 - h.panel].mean(axis=0)
                into = -n if (other - h.center) @ n > 0 else n
                out.append(FastenerPlacement(f, p.name, i, "", h.center - 0.5 * t * into, into,
                                             t + ANCHOR_EMBEDMENT * d))
                continue
            host, into, plies = "", n, 2
            if plate_tree is not None:
                dist, k = plate_tree.query(h.center)
                if dist <= 2 * t:
                    host = hosts[k]
                    into = n if (centres[k] - h.center) @ n >= 0 else -n
                    beyond = h.center + 2 * t * into       # a connector on the far face
                    if shared_tree is not None and shared_tree.query(beyond)[0] <= 0.5 * t:
                        plies = 3
            out.append(FastenerPlacement(f, p.name, i, host, h.center - 0.5 * t * into, into,
                                         plies * t + BOLT_PROTRUSION * d))
    return out


# ------------------------------------------------------------------ the file
#: IFC's base-64 digits (``ifcopenshell.guid``'s), in the order of the standard alphabet's
_IFC_DIGITS = bytes.maketrans(
    b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/",
    b"0123456789ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz_$")


def _guid(namespace: uuid.UUID, key: str) -> str:
    """A GlobalId that stays the same for the same element of the same project (a re-export
    replaces the elements in a BIM tool instead of adding copies): ``ifcopenshell.guid.compress``
    of ``uuid.uuid5(namespace, key)``, the same 22 characters made from the UUID's bytes (two
    zero bytes before its 16, in base 64, the first two digits dropped) without its hex text
    (thousands of elements per file)."""
    import base64

    return base64.b64encode(b"\0\0" + uuid.uuid5(namespace, key).bytes)[2:].translate(
        _IFC_DIGITS).decode()


def _dms(degrees: float) -> tuple[int, int, int, int]:
    """Degrees as IFC's compound plane angle (degrees, minutes, seconds, millionths of a
    second), every part with the sign of the angle."""
    sign = -1 if degrees < 0 else 1
    micro = int(round(abs(degrees) * 3600e6))
    d, rest = divmod(micro, 3600 * 10 ** 6)
    m, rest = divmod(rest, 60 * 10 ** 6)
    s, u = divmod(rest, 10 ** 6)
    return sign * d, sign * m, sign * s, sign * u


#: the unit vectors along x, y, z (rows)
_AXES = np.eye(3)


def _perpendicular(z: np.ndarray) -> np.ndarray:
    """A unit vector square to the unit vector ``z``."""
    a = _AXES[int(np.argmin(np.abs(z)))]
    x = a - (a @ z) * z
    return x / np.linalg.norm(x)


class _Writer:
    """Builds one IFC4 file: the project and its spatial structure, then elements into it.
    Bulk entities are made with ``create_entity`` (the API's calls cost about a millisecond
    each); the project, units and contexts with ``ifcopenshell.api``."""

    def __init__(self, fs, *, project: str, site: dict, material: str, density: float,
                 fastener_material: str):
        import ifcopenshell
        import ifcopenshell.api.context
        import ifcopenshell.api.project
        import ifcopenshell.api.root

        self.fs = fs
        self.ns = uuid.uuid5(uuid.NAMESPACE_URL, f"torsal:{project}")
        f = self.f = ifcopenshell.api.project.create_file(version="IFC4")
        proj = ifcopenshell.api.root.create_entity(f, ifc_class="IfcProject", name=project)
        proj.GlobalId = _guid(self.ns, "project")
        self._units(proj, density)
        model = ifcopenshell.api.context.add_context(f, context_type="Model")
        if site.get("north_angle") is not None:
            a = np.radians(site["north_angle"])
            model.TrueNorth = f.createIfcDirection((float(-np.sin(a)), float(np.cos(a))))
        self.body = ifcopenshell.api.context.add_context(
            f, context_type="Model", context_identifier="Body", target_view="MODEL_VIEW", parent=model)
        self.origin = f.createIfcAxis2Placement3D(f.createIfcCartesianPoint((0.0, 0.0, 0.0)))
        self.up = f.createIfcDirection((0.0, 0.0, 1.0))
        self.properties, self.fastener_shapes = {}, {}
        parent, placement = proj, None
        for cls, name in (("IfcSite", site["name"]), ("IfcBuilding", site["building"]),
                          ("IfcBuildingStorey", site["storey"])):
            el = ifcopenshell.api.root.create_entity(f, ifc_class=cls, name=name)
            el.GlobalId = _guid(self.ns, cls)
            placement = el.ObjectPlacement = f.createIfcLocalPlacement(placement, self.origin)
            # the relation made directly: the API's assign_object re-places the element
            f.createIfcRelAggregates(_guid(self.ns, f"aggregates:{cls}"), None, None, None,
                                     parent, [el])
            parent = el
        self.storey, self.storey_placement = parent, placement
        self.site = f.by_type("IfcSite")[0]
        self._georeference(site)
        self.styles = {}
        self._materials(material, density, fastener_material)

    def _units(self, project, density: float) -> None:
        """Lengths in the fin system's unit, areas m^2, volumes m^3, angles radians, mass kg,
        mass density kg/m^3."""
        import ifcopenshell.api.unit

        f = self.f
        prefix, conversion = _LENGTH_UNITS[self.fs.unit]
        if conversion is None:
            length = ifcopenshell.api.unit.add_si_unit(f, unit_type="LENGTHUNIT", prefix=prefix)
        else:
            length = ifcopenshell.api.unit.add_conversion_based_unit(f, name=conversion)
        units = [length] + [ifcopenshell.api.unit.add_si_unit(f, unit_type=kind, prefix=pre)
                            for kind, pre in (("AREAUNIT", None), ("VOLUMEUNIT", None),
                                              ("PLANEANGLEUNIT", None), ("MASSUNIT", "KILO"))]
        metre = f.createIfcSIUnit(UnitType="LENGTHUNIT", Name="METRE")
        units.append(f.createIfcDerivedUnit(
            [f.createIfcDerivedUnitElement(units[-1], 1), f.createIfcDerivedUnitElement(metre, -3)],
            "MASSDENSITYUNIT", None))
        assignment = ifcopenshell.api.unit.assign_unit(f, units=units)
        # the API gathers them in a Python set (an order by memory address): in the order made
        assignment.Units = sorted(assignment.Units, key=lambda u: u.id())

    def _georeference(self, site: dict) -> None:
        """The site's latitude, longitude (compound angles) and elevation (project unit)."""
        if site.get("latitude") is not None:
            self.site.RefLatitude = _dms(site["latitude"])
            self.site.RefLongitude = _dms(site["longitude"])
            metres = float(site.get("elevation") or 0.0)
            self.site.RefElevation = metres * 1000.0 / UNIT_TO_MM[self.fs.unit]

    def _materials(self, material: str, density: float, fastener_material: str) -> None:
        """The plates' material and layer set (one layer, ``thickness``), the fasteners'."""
        f, t = self.f, self.fs.thickness
        self.material = f.createIfcMaterial(material, None, None)
        f.createIfcMaterialProperties("Pset_MaterialCommon", None, [f.createIfcPropertySingleValue(
            "MassDensity", None, f.createIfcMassDensityMeasure(float(density)), None)], self.material)
        layer = f.createIfcMaterialLayer(self.material, t, None, material, None, None, None)
        self.layer_set = f.createIfcMaterialLayerSet([layer], f"{material} {t:g} {self.fs.unit}", None)
        self.fastener_material = f.createIfcMaterial(fastener_material, None, None)

    def style(self, rgb) -> object:
        """A surface style of colour ``rgb`` (0..1), made once per colour."""
        key = tuple(round(float(c), 6) for c in rgb)
        if key not in self.styles:
            colour = self.f.createIfcColourRgb(None, *key)
            shading = self.f.createIfcSurfaceStyleShading(colour, 0.0)
            self.styles[key] = self.f.createIfcSurfaceStyle(None, "BOTH", [shading])
        return self.styles[key]

    def placement(self, relative_to, origin, z=None, x=None) -> object:
        """An ``IfcLocalPlacement`` at ``origin`` (axes ``z``, ``x``; default the parent's)."""
        f = self.f
        axis = f.createIfcAxis2Placement3D(
            f.createIfcCartesianPoint(tuple(map(float, origin))),
            None if z is None else f.createIfcDirection(tuple(map(float, z))),
            None if x is None else f.createIfcDirection(tuple(map(float, x))))
        return f.createIfcLocalPlacement(relative_to, axis)

    def shape(self, item, kind: str, rgb) -> object:
        """The body representation of one solid ``item`` (``kind``: IFC's representation type),
        coloured ``rgb``."""
        self.f.createIfcStyledItem(item, [self.style(rgb)], None)
        rep = self.f.createIfcShapeRepresentation(self.body, "Body", kind, [item])
        return self.f.createIfcProductDefinitionShape(None, None, [rep])

    def pset(self, element, name: str, values: dict, *, guid: str | None = None) -> None:
        """A property set ``name`` of ``values`` (``{property: (IFC value type, value)}``, e.g.
        ``("IfcLabel", "F0-S000-P00")``) on ``element`` (whose GlobalId is ``guid``, default
        read from it); a property of the same name and value is made once and shared by the
        sets (its value entity too: value entities take no line of the file)."""
        f = self.f
        props = []
        for k, (kind, v) in values.items():
            key = (k, kind, v)
            if key not in self.properties:
                self.properties[key] = f.createIfcPropertySingleValue(
                    k, None, f.create_entity(kind, v), None)
            props.append(self.properties[key])
        guid = element.GlobalId if guid is None else guid
        pset = f.createIfcPropertySet(_guid(self.ns, f"{name}:{guid}"), None, name, None, props)
        f.createIfcRelDefinesByProperties(_guid(self.ns, f"{name}-rel:{guid}"), None,
                                          None, None, [element], pset)

    def write(self, path: Path) -> None:
        # stamped as the STEP file is (SOURCE_DATE_EPOCH, else a fixed date), not with the
        # clock: the same design writes the same bytes
        self.f.header.file_name.time_stamp = _time_stamp()
        self.f.write(str(path))


def _extruded(w: _Writer, part: Part, prof: _Profile, relative_to):
    """Placement and ``IfcExtrudedAreaSolid`` of a flat plate: its profile with the part's
    holes as circles (their centres projected on the plate's plane)."""
    f = w.f
    pts = [f.createIfcCartesianPoint(tuple(map(float, p))) for p in prof.outer]
    outer = f.createIfcPolyline(pts + pts[:1])
    inner = []
    for loop in prof.inner:
        ring = [f.createIfcCartesianPoint(tuple(map(float, p))) for p in loop]
        inner.append(f.createIfcPolyline(ring + ring[:1]))
    for h in part.holes:
        c = prof.local(h.center)[0]
        inner.append(f.createIfcCircle(f.createIfcAxis2Placement2D(
            f.createIfcCartesianPoint(tuple(map(float, c))), None), 0.5 * float(h.diameter)))
    if inner:
        area = f.createIfcArbitraryProfileDefWithVoids("AREA", part.name, outer, inner)
    else:
        area = f.createIfcArbitraryClosedProfileDef("AREA", part.name, outer)
    solid = f.createIfcExtrudedAreaSolid(area, w.origin, w.up,
                                         float(prof.depth))
    return w.placement(relative_to, prof.origin, prof.z_dir, prof.x_dir), solid, "SweptSolid"


def _triangulated(w: _Writer, part: Part, shape, tolerance: float, relative_to):
    """Placement and closed ``IfcTriangulatedFaceSet`` of a part's solid (coordinates from the
    corner of its bounding box). ValueError if its triangles do not close."""
    vertices, tri, closed = closed_triangles(shape, tolerance)
    if not closed:
        raise ValueError(f"{part.name}: its solid's triangles do not make a closed surface")
    corner = vertices.min(axis=0)
    # (lists of Python floats and ints, made by numpy at once: the same values)
    points = w.f.createIfcCartesianPointList3D((vertices - corner).tolist())
    item = w.f.createIfcTriangulatedFaceSet(points, None, True,
                                            (tri.astype(np.int64) + 1).tolist(), None)
    return w.placement(relative_to, corner), item, "Tessellation"


def _part_element(w: _Writer, part: Part, shape, info: dict, joints: list, *, relative_to,
                  flat_profiles: bool, tolerance: float):
    """The ``IfcPlate`` of one part, with its body, property sets and material."""
    f = w.f
    prof = prism_profile(shape, w.fs.thickness) if flat_profiles and _flat(part) else None
    if prof is not None:
        placement, item, kind = _extruded(w, part, prof, relative_to)
    else:
        placement, item, kind = _triangulated(w, part, shape, tolerance, relative_to)
    body = PlateBody.EXTRUSION if prof is not None else PlateBody.TRIANGULATED
    fin = part.family not in (CONNECTOR_FAMILY, FIXING_FAMILY)
    guid = _guid(w.ns, part.name)
    el = f.createIfcPlate(guid, None, part.name, _description(part, info),
                          None if fin else info["kind"], placement, w.shape(item, kind, part.color),
                          part.name, "SHEET" if fin else "USERDEFINED")
    w.pset(el, "Torsal_Part", {
        "PartName": ("IfcLabel", part.name), "Family": ("IfcInteger", part.family),
        "Strip": ("IfcInteger", part.id.strip), "Panel": ("IfcInteger", part.id.index),
        "JointKind": ("IfcLabel", info["kind"]),
        "Joints": ("IfcText", ", ".join(joints) or "none"),
        "Panels": ("IfcInteger", len(part.panels)), "Holes": ("IfcInteger", info["holes"]),
        "Fastener": ("IfcLabel", info["fastener"] or "none"),
        "Thickness": ("IfcPositiveLengthMeasure", float(w.fs.thickness)),
        "Body": ("IfcLabel", body.value)}, guid=guid)
    w.pset(el, "Pset_PlateCommon", {"Reference": ("IfcIdentifier", part.name),
                                    "IsExternal": ("IfcBoolean", True),
                                    "LoadBearing": ("IfcBoolean", False)}, guid=guid)
    return el, body


def _flat(part: Part) -> bool:
    """Whether a part can be a right prism: its panels on one plane, its mitre vectors along
    their normal (square ends); :func:`prism_profile` then checks its solid."""
    n = quad_normals(part.panels)
    if not (np.abs(n @ n[0]) >= 1.0 - 1e-12).all():
        return False
    m = part.miters if part.miters is not None else n[:1]
    across = np.linalg.norm(np.cross(m, n[0]), axis=1)
    return bool(across.max() <= 1e-9 * np.linalg.norm(m, axis=1).max())


def _description(part: Part, info: dict) -> str:
    """A line for a BIM tool's element list."""
    if part.family == CONNECTOR_FAMILY:
        return f"{info['kind']} connector at node {part.id.strip}"
    if part.family == FIXING_FAMILY:
        return f"fixing of fin edge {part.id.strip} to the building"
    return f"fin plate of {len(part.panels)} panel(s), strip {str(part.id)[:-4]}"


def _joints_by_part(fs) -> dict[str, list[str]]:
    """``{part name: ["egg-crate N0012", ...]}``: the joints each part is in."""
    out: dict[str, list[str]] = {}
    for j in getattr(fs, "joints", []):
        for name in set(j.parts) | ({j.connector} if j.connector else set()):
            out.setdefault(name, []).append(f"{j.kind.value} N{j.node:04d}")
    return out


def _add_parts(w: _Writer, *, flat_profiles: bool, tolerance: float) -> dict[str, int]:
    """Every part (strips' plates aggregated into an ``IfcElementAssembly`` each, connectors
    and fixings in the storey) with its material; returns the count of each body kind."""
    f, fs = w.f, w.fs
    shapes, info, joints = solid_shapes(fs), part_fastening(fs), _joints_by_part(fs)
    strips: dict[tuple, list[Part]] = {}
    for p in fs.plates:
        strips.setdefault((p.family, p.id.strip), []).append(p)
    counts = {b: 0 for b in PlateBody}
    by_body: dict[PlateBody, list] = {b: [] for b in PlateBody}
    in_storey = []
    for (family, strip), parts in strips.items():
        name = str(PartId(family, strip, 0))[:-4]
        placement = w.placement(w.storey_placement, (0.0, 0.0, 0.0))
        asm = f.createIfcElementAssembly(_guid(w.ns, f"strip:{name}"), None, name,
                                         f"fin strip of {len(parts)} part(s)", "fin strip",
                                         placement, None, name, "SITE", "USERDEFINED")
        w.pset(asm, "Torsal_Strip", {"Strip": ("IfcLabel", name), "Family": ("IfcInteger", family),
                                     "Parts": ("IfcInteger", len(parts))})
        members = []
        for p in parts:
            el, body = _part_element(w, p, shapes[p.name], info[p.name], joints.get(p.name, []),
                                     relative_to=placement, flat_profiles=flat_profiles,
                                     tolerance=tolerance)
            members.append(el)
            by_body[body].append(el)
        f.createIfcRelAggregates(_guid(w.ns, f"aggregates:{name}"), None, None, None, asm, members)
        in_storey.append(asm)
    for p in fs.connectors + fs.fixings:
        el, body = _part_element(w, p, shapes[p.name], info[p.name], joints.get(p.name, []),
                                 relative_to=w.storey_placement, flat_profiles=flat_profiles,
                                 tolerance=tolerance)
        by_body[body].append(el)
        in_storey.append(el)
    for body, elements in by_body.items():
        counts[body] = len(elements)
        if elements:
            # a flat plate's layers run along its extrusion; another's along no axis it has
            # (made only when used: a usage must be associated with an element)
            use = (f.createIfcMaterialLayerSetUsage(w.layer_set, "AXIS3", "POSITIVE", 0.0, None)
                   if body is PlateBody.EXTRUSION else w.layer_set)
            f.createIfcRelAssociatesMaterial(_guid(w.ns, f"material:{body.value}"), None, None,
                                             None, elements, use)
    w.in_storey = in_storey
    return counts


def _add_fasteners(w: _Writer) -> int:
    """Every bolt and anchor (:func:`fastener_placements`) as an ``IfcMechanicalFastener``:
    a cylinder of its nominal diameter along its shank."""
    f, fs = w.f, w.fs
    mm = UNIT_TO_MM[fs.unit]
    elements = []
    for fp in fastener_placements(fs):
        d = fp.fastener.bolt_mm / mm
        shape = (fp.fastener.label, round(float(fp.length), 9))
        if shape not in w.fastener_shapes:      # one body per size and length, shared
            profile = f.createIfcCircleProfileDef("AREA", fp.fastener.name, None, 0.5 * d)
            item = f.createIfcExtrudedAreaSolid(profile, w.origin, w.up, float(fp.length))
            w.fastener_shapes[shape] = w.shape(item, "SweptSolid", (0.6, 0.6, 0.62))
        placement = w.placement(w.storey_placement, fp.start, fp.direction,
                                _perpendicular(fp.direction))
        key = f"{fp.part}.{fp.hole}"
        guid = _guid(w.ns, f"fastener:{key}")
        el = f.createIfcMechanicalFastener(
            guid, None, fp.fastener.label,
            f"{fp.fastener.label} through {fp.part}"
            + (f" and {fp.host}" if fp.host else " into the building"),
            None, placement, w.fastener_shapes[shape], key, d, float(fp.length),
            _FASTENER_TYPES[fp.fastener.kind])
        w.pset(el, "Torsal_Fastener", {
            "Fastener": ("IfcLabel", fp.fastener.label), "Part": ("IfcLabel", fp.part),
            "Hole": ("IfcInteger", fp.hole), "Host": ("IfcLabel", fp.host or "building"),
            "HoleDiameter": ("IfcPositiveLengthMeasure", fp.fastener.hole_mm / mm)}, guid=guid)
        elements.append(el)
    if elements:
        f.createIfcRelAssociatesMaterial(_guid(w.ns, "material:fasteners"), None, None, None,
                                         elements, w.fastener_material)
    w.in_storey += elements
    return len(elements)


def export_ifc(fin_system, path, *, project: str = "torsal fins", latitude: float | None = None,
               longitude: float | None = None, elevation: float = 0.0,
               north_angle: float | None = None, site_name: str = "site",
               building_name: str = "building", storey_name: str = "fins",
               material: str = "aluminium", density: float = 2700.0,
               fastener_material: str = "stainless steel", flat_profiles: bool = True,
               tolerance: float | None = None) -> Path:
    """Write a fin system as one IFC4 file for BIM tools (see the module's description).

    Parameters
    ----------
    fin_system : FinSystem
        A finished fin system; its solids are built if they are not yet (as for STEP).
    path : str or Path
        The ``.ifc`` file, written atomically (a failure leaves no half-written file).
    project : str
        The project's name; with each part's name it fixes the elements' GlobalIds, so a
        later export of the same project replaces them in a BIM tool.
    latitude, longitude : float or None
        Degrees north and east of the site (both or neither).
    elevation : float
        Metres above sea level of the site's origin.
    north_angle : float or None
        Degrees: true north counter-clockwise from the model's ``+y`` (as the design file's
        ``site.north_angle``); None: not stated.
    site_name, building_name, storey_name : str
        Names of the spatial elements.
    material : str
        The plates' material (its name; ``thickness`` from the fin system).
    density : float
        Its mass density (kg/m^3), > 0.
    fastener_material : str
        The bolts' and anchors' material.
    flat_profiles : bool
        Flat plates as extruded profiles (default); False: every part triangulated.
    tolerance : float or None
        Deflection of curved faces when triangulating (``unit``; default
        :data:`~.plates.MESH_TOLERANCE` x thickness); plane faces are exact.

    Returns
    -------
    Path
        ``path``.

    Raises
    ------
    ValueError
        An unknown unit, a bad density, latitude without longitude, or a solid whose
        triangles do not close.

    Examples
    --------
    >>> fs = FinSystem(structure, thickness=3.0)                       # doctest: +SKIP
    >>> export_ifc(fs, "out/fins.ifc", latitude=48.21, longitude=16.37,
    ...            north_angle=0.0, material="aluminium")              # doctest: +SKIP
    PosixPath('out/fins.ifc')
    """
    if fin_system.unit not in _LENGTH_UNITS:
        raise ValueError(f"unit {fin_system.unit!r} has no IFC length unit here; use one of "
                         f"{sorted(_LENGTH_UNITS)}")
    if not (np.isfinite(density) and density > 0):
        raise ValueError(f"density must be > 0 kg/m^3, got {density}")
    if (latitude is None) != (longitude is None):
        raise ValueError("give latitude and longitude together (or neither)")
    site = {"name": site_name, "building": building_name, "storey": storey_name,
            "latitude": latitude, "longitude": longitude, "elevation": elevation,
            "north_angle": north_angle}
    w = _Writer(fin_system, project=project, site=site, material=material, density=density,
                fastener_material=fastener_material)
    tol = tolerance if tolerance is not None else MESH_TOLERANCE * fin_system.thickness
    _add_parts(w, flat_profiles=flat_profiles, tolerance=tol)
    _add_fasteners(w)
    w.f.createIfcRelContainedInSpatialStructure(_guid(w.ns, "storey-contents"), None, None, None,
                                                w.in_storey, w.storey)
    with atomic_path(path) as tmp:
        w.write(tmp)
    return Path(path)


# ------------------------------------------------------------------ in a process of its own
#: attributes of a fin system that hold OpenCascade shapes or live work (they do not pickle):
#: the IFC's process gets the fin system without them and the solids as binary BReps
_LIVE = ("_solids", "_solid_shapes", "_solid_bytes", "_pending", "_breps", "_check_solids")


def _export_in_child(conn) -> None:
    """IFC process: imports ifcopenshell while the solids are collected, then reads the pickled
    ``(fin system, {name: BRep bytes}, path, options)`` from ``conn``, writes the file as
    :func:`export_ifc` does here and answers ``("done", None)`` or ``("error", exception)``;
    ends quietly when ``conn`` closes without a payload."""
    import pickle

    from torsal.core.parallel import portable_error

    from .workers import run_in_background

    run_in_background()          # the STEP file and its reading come first
    import ifcopenshell  # noqa: F401  (seconds: while this process waits)

    try:
        payload = conn.recv_bytes()
    except (EOFError, OSError):
        return
    try:
        fs, data, path, options = pickle.loads(payload)
        from .workers import _from_bytes, _parts_key

        # the same shapes as the exporting process's: both read the workers' bytes
        fs._solid_shapes = (_parts_key(fs), {name: _from_bytes(b) for name, b in data.items()})
        export_ifc(fs, path, **options)
        message = ("done", None)
    except BaseException as exc:             # raised again in the parent
        message = ("error", portable_error(exc))
    try:
        conn.send(message)
        conn.close()
    except OSError:                           # the caller stopped waiting
        pass


class PendingIfc:
    """:func:`export_ifc` running in a process of its own (:func:`start_export_ifc`) while
    this one writes the STEP file: :meth:`result` waits for the file, :meth:`cancel` stops
    it. Where no second process may be started, or the fin system does not pickle,
    :meth:`result` writes the file in this process: the same bytes either way."""

    def __init__(self, fin_system, path, options: dict):
        import pickle
        import threading

        from torsal.core.parallel import usable_workers

        from .workers import _context, solid_bytes

        self.fin_system, self.path, self.options = fin_system, Path(path), options
        self._process = self._conn = None
        if usable_workers(2) < 2:
            return
        state = {k: v for k, v in vars(fin_system).items() if k not in _LIVE}
        fs = object.__new__(type(fin_system))
        fs.__dict__.update(state)
        try:
            payload = pickle.dumps((fs, solid_bytes(fin_system), str(self.path), options),
                                   protocol=pickle.HIGHEST_PROTOCOL)
        except Exception:        # a fin system holding something that does not pickle
            return
        self._conn, child = _context().Pipe(duplex=True)
        self._process = _context().Process(target=_export_in_child, args=(child,),
                                           name="torsal-ifc", daemon=True)
        self._process.start()
        child.close()
        # the process reads its payload once ifcopenshell is imported: a thread waits for it
        self._sender = threading.Thread(target=self._send, args=(payload,), daemon=True)
        self._sender.start()

    def _send(self, payload: bytes) -> None:
        try:
            self._conn.send_bytes(payload)
        except OSError:          # the process ended (cancelled): result() says so
            pass

    def result(self) -> Path:
        """``path``, written (waits); the exporter's error raised again here."""
        if self._process is None:
            return export_ifc(self.fin_system, self.path, **self.options)
        from .workers import child_answer

        kind, value = child_answer(self._conn, self._process, f"the IFC export of {self.path.name}")
        self._sender.join()
        if kind == "error":
            raise value
        return self.path

    def cancel(self) -> None:
        """Stop the export (a later step failed); no file is left (it is written atomically)."""
        if self._process is not None and self._process.is_alive():
            self._process.terminate()
            self._process.join()


def start_export_ifc(fin_system, path, **options) -> PendingIfc:
    """:func:`export_ifc` of ``fin_system`` to ``path`` in a process of its own, started now
    (after its solids are collected, here): returns at once a :class:`PendingIfc` whose
    ``result()`` is ``path``, written. The design's fabrication writes the STEP file
    meanwhile (the IFC's 3-4 s of ifcopenshell on 7a would wait for it, one core idle).

    >>> pending = start_export_ifc(fs, "fins.ifc", latitude=48.21, longitude=16.37)  # doctest: +SKIP
    >>> write_step_meanwhile()                                                     # doctest: +SKIP
    >>> pending.result()                                                           # doctest: +SKIP
    PosixPath('fins.ifc')
    """
    solid_shapes(fin_system)            # collected (or built) here: the process reads their bytes
    return PendingIfc(fin_system, path, options)
