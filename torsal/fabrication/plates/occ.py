"""Small OpenCascade helpers: a box on a plane, a shape's volume, BRepCheck (and ShapeFix
where asked), a shape as its own type, the solids in a shape."""
from __future__ import annotations

import numpy as np


def _box(origin, x_dir, z_dir, length, width, height):
    """OCC box ``length x width x height`` from ``origin`` along ``x_dir``, ``z_dir x x_dir``,
    ``z_dir`` (as build123d's ``Solid.make_box`` on that plane)."""
    from OCP.BRepPrimAPI import BRepPrimAPI_MakeBox
    from OCP.gp import gp_Ax2, gp_Dir, gp_Pnt

    def unit(v):
        v = np.asarray(v, float)
        return gp_Dir(*map(float, v / np.linalg.norm(v)))

    ax = gp_Ax2(gp_Pnt(*map(float, origin)), unit(z_dir), unit(x_dir))
    return BRepPrimAPI_MakeBox(ax, float(length), float(width), float(height)).Shape()


def _volume(shape) -> float:
    """Volume of an OCC shape (signed: negative for a solid turned inside out)."""
    from OCP.BRepGProp import BRepGProp
    from OCP.GProp import GProp_GProps

    props = GProp_GProps()
    BRepGProp.VolumeProperties_s(shape, props)
    return props.Mass()


def _is_valid(shape) -> bool:
    """BRepCheck of an OCC shape (as build123d's ``is_valid``)."""
    from OCP.BRepCheck import BRepCheck_Analyzer

    chk = BRepCheck_Analyzer(shape)
    chk.SetParallel(True)
    return chk.IsValid()


def _valid(shape, repair: bool):
    """The shape if BRepCheck finds it valid, else (with ``repair``) what ShapeFix makes of it
    if that is valid, else None."""
    if _is_valid(shape):
        return shape
    if not repair:
        return None
    from OCP.ShapeFix import ShapeFix_Shape

    fix = ShapeFix_Shape(shape)
    fix.Perform()
    fixed = _downcast(fix.Shape())
    return fixed if _is_valid(fixed) else None


def _downcast(shape):
    """The OCC shape as its own type (TopoDS_Solid, TopoDS_Compound, ...)."""
    from OCP.TopAbs import TopAbs_COMPOUND, TopAbs_SHELL, TopAbs_SOLID
    from OCP.TopoDS import TopoDS

    cast = {TopAbs_SOLID: TopoDS.Solid, TopAbs_COMPOUND: TopoDS.Compound,
            TopAbs_SHELL: TopoDS.Shell}.get(shape.ShapeType())
    return cast(shape) if cast is not None else shape


def _solids_of(shape) -> list:
    """The OCC solids in a shape."""
    from OCP.TopAbs import TopAbs_SOLID
    from OCP.TopExp import TopExp_Explorer
    from OCP.TopoDS import TopoDS

    out, exp = [], TopExp_Explorer(shape, TopAbs_SOLID)
    while exp.More():
        out.append(TopoDS.Solid(exp.Current()))
        exp.Next()
    return out
