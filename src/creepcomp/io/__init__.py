"""Reading and writing files: measured records (CSV, ``records``), model and design files
(JSON, ``jsonfiles``), and atomic output (``atomic``)."""

from creepcomp.io import atomic, records, jsonfiles
from creepcomp.io.atomic import *  # noqa: F401,F403
from creepcomp.io.records import *  # noqa: F401,F403
from creepcomp.io.jsonfiles import *  # noqa: F401,F403

__all__ = atomic.__all__ + records.__all__ + jsonfiles.__all__
