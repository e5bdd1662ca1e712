"""Reading and writing files: measured records (CSV, ``records``) and model and design files
(JSON, ``jsonfiles``)."""

from creepcomp.io import records, jsonfiles
from creepcomp.io.records import *  # noqa: F401,F403
from creepcomp.io.jsonfiles import *  # noqa: F401,F403

__all__ = records.__all__ + jsonfiles.__all__
