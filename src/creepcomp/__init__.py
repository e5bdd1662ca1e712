"""creepcomp: remove creep from elastomer-based sensors.

The Python API behind the ``creepcomp`` command: creep models, correction networks, their
sizing and E-series snapping, and their predicted quality.
"""

from .errors import CreepcompError, InputError, NotRealisableError
from .files import Design, read_design, read_model, write_design, write_model
from .lti import LagExpansion
from .model import CreepModel
from .network import Branch, Cell, Network
from .quality import Quality, predict
from .sizing import SizingReport, ideal_network, size

__version__ = "0.1.0"

__all__ = [
    "CreepcompError", "InputError", "NotRealisableError", "Design", "read_design", "read_model",
    "write_design", "write_model", "LagExpansion", "CreepModel", "Branch", "Cell", "Network",
    "Quality", "predict", "SizingReport", "ideal_network", "size",
]
