"""A B-spline facade made in FreeCAD (mm): the kind of surface an architect links as the fins'
``Surface``. Used by ``freecad_screenshot.py`` and the FreeCAD test; FreeCAD is imported inside
the function, so this file imports anywhere."""


def facade_face(width: float = 9000.0, height: float = 4500.0):
    """A doubly curved facade in the x-z plane bulging to -y (south), saddle-shaped like
    torsal's ``facade_patch`` (anticlastic, so its normal congruence is hyperbolic): a
    ``Part.Face`` on a B-spline surface through 5 x 4 points."""
    import FreeCAD
    import Part

    rows = []
    for i in range(5):
        s = -0.5 + i / 4
        row = []
        for j in range(4):
            t = -0.5 + j / 3
            y = -0.075 * width * (1 - 4 * s * s) - 0.27 * height * t * t - 0.1 * height * s * t
            row.append(FreeCAD.Vector(s * width, y, (t + 0.5) * height))
        rows.append(row)
    surface = Part.BSplineSurface()
    surface.interpolate(rows)
    return surface.toShape()
