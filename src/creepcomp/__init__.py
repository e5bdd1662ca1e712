"""creepcomp: remove creep from elastomer-based sensors.

The Python API behind the ``creepcomp`` command: creep models, correction networks, their
sizing and E-series snapping, and their predicted quality.
"""

from creepcomp.errors import CreepcompError, InputError, NotRealisableError
from creepcomp.io.jsonfiles import Design, read_design, read_model, write_design, write_model
from creepcomp.lti import LagExpansion
from creepcomp.model import CreepModel
from creepcomp.network import Branch, Cell, Network
from creepcomp.analog.quality import Quality, predict
from creepcomp.analog.sizing import SizingReport, ideal_network, size

__version__ = "0.1.0"

__all__ = [
    "CreepcompError", "InputError", "NotRealisableError", "Design", "read_design", "read_model",
    "write_design", "write_model", "LagExpansion", "CreepModel", "Branch", "Cell", "Network",
    "Quality", "predict", "SizingReport", "ideal_network", "size",
]
