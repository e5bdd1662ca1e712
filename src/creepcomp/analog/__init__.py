"""The analog correction network: sizing (``sizing``), predicted quality (``quality``), E-series
parts (``eseries``), faults of a built network and their fixes (``faults``)."""

from creepcomp.analog import quality, eseries, sizing, faults
from creepcomp.analog.quality import *  # noqa: F401,F403
from creepcomp.analog.eseries import *  # noqa: F401,F403
from creepcomp.analog.sizing import *  # noqa: F401,F403
from creepcomp.analog.faults import *  # noqa: F401,F403

__all__ = quality.__all__ + eseries.__all__ + sizing.__all__ + faults.__all__
