"""The errors a part's solid raises: :class:`InvalidSolidError` (the solid is not valid
OpenCascade geometry even after repair) and :class:`SlotCutError` (the plate is sound, its slots
could not be cut)."""
from __future__ import annotations

from torsal.core.errors import TorsalError


class InvalidSolidError(TorsalError, RuntimeError):
    """A part's solid is not valid OpenCascade geometry even after repair."""

    #: what a designer can do about it (said after the detail)
    ADVICE = ("; its fin panels are twisted or folded back too far to make a plate: keep the fins' "
              "torsal planes apart ([constraints] min_torsal_angle, e.g. 30) or smooth the "
              "congruence (weights.fair), or remesh the surface more finely")

    def __init__(self, parts: list[str], detail: str = ""):
        self.parts = parts
        self.detail = detail
        super().__init__(f"invalid solid for part(s) {', '.join(parts)}" + (f": {detail}" if detail else "")
                         + (self.ADVICE if type(self) is InvalidSolidError else ""))


class SlotCutError(InvalidSolidError):
    """The plate of a part is sound but OpenCascade could not cut its slots (a boolean failure
    on a thin, oblique plate). ``plate`` is the valid solid without slots (a build123d ``Solid``
    from :func:`part_solid`, an OCC shape inside the module)."""

    def __init__(self, parts: list[str], detail: str = "", plate=None, nodes=()):
        super().__init__(parts, detail)
        self.plate = plate
        self.nodes = list(nodes)
