"""The price of a design from the user's rates and its bill of quantities (issue 42).

torsal invents no prices: without :class:`Rates` there is no price (:func:`price` returns
None). With them every quantity is priced by its rate, one named :class:`PriceLine` each, and
the :class:`Price`'s total is the sum of its lines:

=================  ==========================================  ===================================
line               quantity                                    rate
=================  ==========================================  ===================================
material           gross kg (the sheets used), or sheets       ``material_per_kg`` or
                                                               ``material_per_sheet``
cutting            m of contour cut                            ``cut_per_m[process]``
pierces            closed contours cut                         ``per_pierce``
bends              bends                                       ``per_bend``
fasteners <label>  fasteners of that size and kind             ``fasteners["M6 bolt"]``, else
                                                               ``fasteners["bolt"]``
placing parts      min: parts x ``minutes_per_part``           ``per_minute``
setting fasteners  min: fasteners x ``minutes_per_fastener``   ``per_minute``
drilling holes     min: holes drilled x                        ``per_minute``
                   ``minutes_per_hole_drilled``
=================  ==========================================  ===================================

Rates are in the user's currency (``currency``, a label only) per unit of the quantity.

Example
-------
>>> rates = Rates(material_per_kg=6.0, cut_per_m={Process.LASER: 1.5}, per_pierce=0.05,
...               per_bend=0.8, fasteners={"bolt": 0.3, "anchor": 2.0}, per_minute=1.0,
...               minutes_per_part=3.0, minutes_per_fastener=1.0, minutes_per_hole_drilled=0.5)
>>> price(quantities, None) is None                                  # doctest: +SKIP
True
>>> p = price(quantities, rates, surface_m2=120.0)                   # doctest: +SKIP
>>> p.total == sum(line.amount for line in p.lines)                  # doctest: +SKIP
True
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from enum import Enum
from typing import Mapping

from ..cutting import Process
from .bill import FastenerKind, Quantities, split_fastener

__all__ = ["CostLine", "Rates", "PriceLine", "Price", "price", "check_fastener_rates"]


class CostLine(str, Enum):
    """The lines of a price."""

    MATERIAL = "material"
    CUTTING = "cutting"
    PIERCES = "pierces"
    BENDS = "bends"
    FASTENERS = "fasteners"
    PLACING = "placing parts"
    FASTENING = "setting fasteners"
    DRILLING = "drilling holes"


def _check_rate(name: str, value) -> None:
    if not (isinstance(value, (int, float)) and math.isfinite(value) and value >= 0):
        raise ValueError(f"{name} = {value!r} must be a number >= 0")


def check_fastener_rates(rates: Mapping[str, float]) -> None:
    """ValueError unless ``rates`` prices every :class:`FastenerKind` by kind (``"bolt"``,
    ``"anchor"``) and every other key is a size and a kind (``"M8 anchor"``), each rate a
    number >= 0."""
    kinds = {k.value for k in FastenerKind}
    for key, value in rates.items():
        if key not in kinds:
            size, _ = split_fastener(key)          # names the key if it is not '<size> <kind>'
            if not size:
                raise ValueError(f"fastener {key!r} has no size; write e.g. 'M6 bolt'")
        _check_rate(f"the rate of fastener {key!r}", value)
    missing = sorted(kinds - set(rates))
    if missing:
        raise ValueError(f"no fastener rate for the kinds {missing}; give one per kind "
                         f"({', '.join(sorted(kinds))}), and per size where it differs "
                         "(e.g. 'M8 anchor')")


#: the rates of :class:`Rates` that are one number each
_PLAIN_RATES = ("per_pierce", "per_bend", "per_minute", "minutes_per_part", "minutes_per_fastener",
                "minutes_per_hole_drilled")


@dataclass(frozen=True, kw_only=True)
class Rates:
    """The user's rates, in ``currency`` per unit of each quantity.

    Parameters
    ----------
    material_per_kg, material_per_sheet : float or None
        Exactly one: per kg of the sheets used (gross), or per sheet.
    cut_per_m : mapping of Process to float
        Per metre of contour cut, by cutting process.
    per_pierce, per_bend : float
        Per closed contour cut, per bend.
    fasteners : mapping of str to float
        Per fastener: by kind (``"bolt"``, ``"anchor"``: every kind needs one) and, where a
        size costs otherwise, by size and kind (``"M8 anchor"``).
    per_minute : float
        Per minute of assembly.
    minutes_per_part, minutes_per_fastener, minutes_per_hole_drilled : float
        Minutes to place a part, to set a fastener, to drill a hole.
    currency : str
        A label for the report (e.g. ``"EUR"``).
    """

    cut_per_m: Mapping[Process, float]
    per_pierce: float
    per_bend: float
    fasteners: Mapping[str, float]
    per_minute: float
    minutes_per_part: float
    minutes_per_fastener: float
    minutes_per_hole_drilled: float
    material_per_kg: float | None = None
    material_per_sheet: float | None = None
    currency: str = ""

    def __post_init__(self):
        if (self.material_per_kg is None) == (self.material_per_sheet is None):
            raise ValueError("give exactly one of material_per_kg (per kg of the sheets used) "
                             "or material_per_sheet")
        for name in _PLAIN_RATES + ("material_per_kg", "material_per_sheet"):
            if getattr(self, name) is not None:
                _check_rate(name, getattr(self, name))
        cut = {Process(k): v for k, v in self.cut_per_m.items()}
        for k, v in cut.items():
            _check_rate(f"cut_per_m.{k.value}", v)
        object.__setattr__(self, "cut_per_m", cut)
        check_fastener_rates(self.fasteners)

    def fastener_rate(self, label: str) -> float:
        """The rate of a fastener (``"M6 bolt"``): by its size and kind if given, else by kind."""
        if label in self.fasteners:
            return float(self.fasteners[label])
        return float(self.fasteners[split_fastener(label)[1].value])


@dataclass(frozen=True)
class PriceLine:
    """One line of a price: ``quantity`` (in ``unit``) times ``rate`` (currency per
    ``unit``); ``detail`` tells lines of one kind apart (a fastener's label)."""

    line: CostLine
    quantity: float
    unit: str
    rate: float
    detail: str = ""

    @property
    def amount(self) -> float:
        return float(self.quantity * self.rate)

    @property
    def name(self) -> str:
        return f"{self.line.value} {self.detail}" if self.detail else self.line.value


@dataclass(frozen=True)
class Price:
    """A design's price: its named lines, their ``total`` (the sum of the lines) and the
    total per m^2 of the design's surface (``surface_m2``; None if not given)."""

    lines: tuple[PriceLine, ...]
    surface_m2: float | None = None
    currency: str = ""

    @property
    def total(self) -> float:
        return float(math.fsum(line.amount for line in self.lines))

    @property
    def per_m2(self) -> float | None:
        return None if not self.surface_m2 else self.total / self.surface_m2

    def as_report(self) -> dict:
        """For report.json: ``total``, ``per_m2``, ``surface_m2``, ``currency`` and
        ``lines`` (by name: quantity, unit, rate, amount)."""
        return {"total": self.total, "per_m2": self.per_m2, "surface_m2": self.surface_m2,
                "currency": self.currency,
                "lines": {ln.name: {"quantity": ln.quantity, "unit": ln.unit, "rate": ln.rate,
                                    "amount": ln.amount} for ln in self.lines}}


def _material_line(q: Quantities, rates: Rates) -> PriceLine:
    if rates.material_per_sheet is not None:
        if q.sheets is None:
            raise ValueError("material_per_sheet prices the sheets used: the quantities need "
                             "the layout")
        return PriceLine(CostLine.MATERIAL, q.sheets, "sheet", rates.material_per_sheet)
    if q.gross_kg is None:
        raise ValueError("material_per_kg prices the sheets used (gross kg): the quantities "
                         "need the layout")
    return PriceLine(CostLine.MATERIAL, q.gross_kg, "kg", rates.material_per_kg)


def price(q: Quantities, rates: Rates | None, *, surface_m2: float | None = None) -> Price | None:
    """The price of a bill of quantities at the user's ``rates`` (None without rates).

    Parameters
    ----------
    q : Quantities
        The design's bill of quantities (:func:`~.bill.bill_of_quantities`).
    rates : Rates or None
    surface_m2 : float, optional
        The design's surface, m^2, for the price per m^2.

    Raises
    ------
    ValueError
        No cutting rate for the quantities' process, or material priced without a layout.
    """
    if rates is None:
        return None
    if q.process is None or q.process not in rates.cut_per_m:
        what = "no cutting process" if q.process is None else f"process {q.process.value!r}"
        raise ValueError(f"cut_per_m has no rate for {what}; rates are given for "
                         f"{[p.value for p in rates.cut_per_m]}")
    a, per_min = q.assembly, rates.per_minute
    lines = [_material_line(q, rates),
             PriceLine(CostLine.CUTTING, q.cut_m, "m", rates.cut_per_m[q.process], q.process.value),
             PriceLine(CostLine.PIERCES, q.pierces, "pierce", rates.per_pierce),
             PriceLine(CostLine.BENDS, q.bends, "bend", rates.per_bend)]
    lines += [PriceLine(CostLine.FASTENERS, n, "piece", rates.fastener_rate(label), label)
              for label, n in q.fasteners.items()]
    lines += [PriceLine(CostLine.PLACING, a.parts_placed * rates.minutes_per_part, "min", per_min),
              PriceLine(CostLine.FASTENING, a.fasteners_set * rates.minutes_per_fastener, "min",
                        per_min),
              PriceLine(CostLine.DRILLING, a.holes_drilled * rates.minutes_per_hole_drilled, "min",
                        per_min)]
    return Price(tuple(lines), surface_m2, rates.currency)
