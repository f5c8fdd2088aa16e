"""Bill of quantities and price of a fin system (issue 42).

* :mod:`.bill`: per part and per design, net and gross material, cut length and pierces
  (holes cut or drilled by the process), bends, fasteners by kind and size, assembly steps;
* :mod:`.price`: the user's :class:`~.price.Rates` and the :class:`~.price.Price` they give
  (no rates, no price).
"""
from torsal.core.lazy import lazy_exports
from .price import CostLine, Price, PriceLine, Rates, check_fastener_rates, price
__getattr__, __dir__ = lazy_exports(__name__, {
    ".bill": ("AssemblySteps", "FastenerKind", "PartQuantities", "Quantities",
              "bill_of_quantities", "part_quantities", "sheet_shares", "split_fastener"),
})

__all__ = ["AssemblySteps", "FastenerKind", "PartQuantities", "Quantities", "bill_of_quantities",
           "part_quantities", "sheet_shares", "split_fastener", "CostLine", "Price", "PriceLine",
           "Rates", "check_fastener_rates", "price"]
