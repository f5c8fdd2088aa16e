"""The builder behind :class:`~torsal.fabrication.parts.FinSystem`, one job per module (issue 15).

:class:`~torsal.fabrication.parts.FinSystem` is the facade: it validates its options and
has :class:`Rebuilder` (:mod:`.rebuild`) run the phases below on it (each phase class takes the
fin system under construction and fills its lists) and build again until every end is trimmed
and every path is clear; :class:`FreeStrips` (:mod:`.free`) makes the parts of free strips.

* :mod:`.strips` reads the structure's strips and cuts them into parts (:class:`StripCutter`);
* :mod:`.ends` decides how every part end is joined (:class:`EndJoiner`): :mod:`.butts` trims
  butted ends (:class:`ButtTrimmer`), :mod:`.connectors` places the brackets and splice plates
  and records the joints (:class:`ConnectorPlacer`);
* :mod:`.crossings` slots the egg-crate crossings and plans each family-1 plate's slide
  (:class:`CrossingSlotter`);
* :mod:`.seams` holds the seams of strips split at a crossing in the other plate's slot,
  without a connector, where the assembly check on the parts around each proves it, and
  names the ones that fall back to brackets (:class:`SlotSeams`);
* :mod:`.tabs` bends the butted end of a bracketed joint into a tab bolted to the plate it
  meets, with no bracket, once the design is settled, where the assembly check on the parts
  around each proves it, and names the brackets that stay (:class:`TabJoints`);
* :mod:`.clash` finds plates that run into each other without a joint (:class:`ClashFinder`);
* :mod:`.paths` orders the parts, gives each butted part its direction and checks its path
  into place (:class:`AssemblyPlanner`);
* :mod:`.held` is the safety net of the load path: a plate hung loose in a slot it would slide
  out of, where no fixing fits, is bolted to the plate it hangs on (the crossing butted) and
  named (``FinSystem.held_crossings``);
* :mod:`.proximity` (panel distance kernels) and :mod:`.memo` (kernel results kept across
  rebuilds) serve them.

The modules import :mod:`torsal.fabrication.model`, :mod:`~torsal.fabrication.joints` and
:mod:`~torsal.fabrication.unroll` and one another in that order, never
:mod:`torsal.fabrication.parts`.
"""
from torsal.core.lazy import lazy_exports
__getattr__, __dir__ = lazy_exports(__name__, {
    ".butts": ("ButtTrimmer",),
    ".clash": ("ClashFinder",),
    ".connectors": ("ConnectorPlacer",),
    ".crossings": ("CrossingSlotter",),
    ".ends": ("EndJoiner",),
    ".free": ("FreeStrips",),
    ".paths": ("AssemblyPlanner",),
    ".rebuild": ("Rebuilder",),
    ".seams": ("SlotSeams",),
    ".strips": ("StripCutter",),
    ".tabs": ("TabJoints",),
})

__all__ = ["StripCutter", "EndJoiner", "ButtTrimmer", "ConnectorPlacer", "CrossingSlotter",
           "ClashFinder", "AssemblyPlanner", "SlotSeams", "TabJoints", "Rebuilder", "FreeStrips"]
