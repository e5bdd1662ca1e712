"""Reading and writing files: measured records (CSV, ``records``), model and design files
(JSON, ``jsonfiles``), atomic output (``atomic``) and output paths
checked before any work (``outputs``)."""

from creepcomp.io import atomic, outputs, records, jsonfiles
from creepcomp.io.atomic import *  # noqa: F401,F403
from creepcomp.io.outputs import *  # noqa: F401,F403
from creepcomp.io.records import *  # noqa: F401,F403
from creepcomp.io.jsonfiles import *  # noqa: F401,F403

__all__ = atomic.__all__ + outputs.__all__ + records.__all__ + jsonfiles.__all__
