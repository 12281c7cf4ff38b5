"""The one dispatcher (issue #33): N pairs of bodies, box or compound, and a mode in; their
answers, in one shape, out. :class:`Dispatcher` (chains per pair: a learned link where a bundle
serves one, then the exact link), :class:`Pairs` and :class:`Shape` (the bodies as it sees them),
:class:`Answers` (the one answer), :class:`Caps` (what a request may cost)."""
from impactnet.models.dispatch.answers import Answers
from impactnet.models.dispatch.plan import Caps, TooManyContacts, TooManyShapePairs
from impactnet.models.dispatch.shapes import Pairs, Shape
from impactnet.models.dispatch.solve import Dispatcher

__all__ = ["Answers", "Caps", "Dispatcher", "Pairs", "Shape", "TooManyContacts",
           "TooManyShapePairs"]
