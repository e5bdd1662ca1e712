"""The analog correction network: sizing (``sizing``), predicted quality (``quality``), E-series
parts (``eseries``), faults of a built network and their fixes (``faults``); whether a design
can be built (``practicality``: the verdict and the way out) and its bill of materials (``bom``);
all of it in one call (``network_design``, imported when used)."""

from creepcomp.analog import quality, eseries, sizing, faults
from creepcomp.analog.quality import *  # noqa: F401,F403
from creepcomp.analog.eseries import *  # noqa: F401,F403
from creepcomp.analog.sizing import *  # noqa: F401,F403
from creepcomp.analog.faults import *  # noqa: F401,F403
from creepcomp.analog import practicality, bom
from creepcomp.analog.practicality import *  # noqa: F401,F403
from creepcomp.analog.bom import *  # noqa: F401,F403

__all__ = (quality.__all__ + eseries.__all__ + sizing.__all__ + faults.__all__
           + practicality.__all__ + bom.__all__)
