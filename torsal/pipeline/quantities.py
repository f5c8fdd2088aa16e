"""The fabrication stage's bill of quantities and price (issue 42): the ``quantities`` and
``costs`` of the ``fabrication`` report section.

``fabrication.quantities`` is the design's bill of quantities
(:func:`torsal.fabrication.quantities.bill_of_quantities`: net and gross material, cut
length and pierces by the design's cutting process, holes drilled, bends, fasteners by kind
and size, assembly steps); ``fabrication.costs`` its price at the design file's ``[costs]``
rates (total, per m^2 of the design's surface, one line per rate), or None without a
``[costs]`` table: torsal invents no prices.

Example
-------
>>> section = quantities_report(spec, fs, layout, structure)           # doctest: +SKIP
>>> section["quantities"]["cut_m"], section["costs"]["total"]          # doctest: +SKIP
"""
from __future__ import annotations

from ..fabrication.quantities import bill_of_quantities, price
from ..geometry.mesh import polygon_areas
from .design_file import DesignSpec

__all__ = ["quantities_report", "surface_area"]


def surface_area(structure) -> float:
    """Area of the design surface as the support structure tiles it: the polygons of A~
    (``structure.faces`` on ``structure.vertices_a``), each split into a fan of triangles
    from its first corner; model units squared. A structure refined into developable strips
    (Fig. 10) has no faces: the area of the faces it was refined from
    (``metadata['surface_area']``, :func:`~torsal.geometry.developable.refine_developable`)."""
    if len(structure.faces) == 0 and "surface_area" in structure.metadata:
        return float(structure.metadata["surface_area"])
    return float(polygon_areas(structure.vertices_a, structure.faces).sum())


def quantities_report(spec: DesignSpec, fs, layout, structure) -> dict:
    """The ``quantities`` and ``costs`` entries of the fabrication report section.

    Parameters
    ----------
    spec : DesignSpec
        Its material's density and its ``[costs]`` rates (None: no price).
    fs : FinSystem
        The design's parts.
    layout : Layout
        The nested sheets (gross material) and their cutting process.
    structure : SupportStructure
        The support structure, model units: its A~ is the surface the price per m^2 divides
        by (:func:`surface_area`).

    Returns
    -------
    dict
        ``{"quantities": {...}, "costs": {...} or None}`` (see
        :meth:`~torsal.fabrication.quantities.Quantities.as_report` and
        :meth:`~torsal.fabrication.quantities.Price.as_report`).
    """
    q = bill_of_quantities(fs, density=spec.material.density, layout=layout)
    surface_m2 = surface_area(structure) * spec.metres_per_unit ** 2
    cost = price(q, None if spec.costs is None else spec.costs.rates(), surface_m2=surface_m2)
    report = q.as_report()
    report["surface_m2"] = surface_m2
    return {"quantities": report, "costs": None if cost is None else cost.as_report()}
