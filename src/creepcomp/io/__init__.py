"""Reading and writing files: measured records (CSV, ``records``), model and design files
(JSON, ``jsonfiles``), atomic output (``atomic``), output paths checked before any work
(``outputs``), input files checked for kind and size before they are read (``inputs``), and
the readers of other measured files: insole ``.mat`` files (``insole``),
creep workbooks (``wood``) and one entry point for all (``formats.read_any``)."""

from creepcomp.io import atomic, inputs, outputs, records, jsonfiles
from creepcomp.io import formats, insole, wood
from creepcomp.io.atomic import *  # noqa: F401,F403
from creepcomp.io.outputs import *  # noqa: F401,F403
from creepcomp.io.inputs import *  # noqa: F401,F403
from creepcomp.io.records import *  # noqa: F401,F403
from creepcomp.io.jsonfiles import *  # noqa: F401,F403
from creepcomp.io.formats import *  # noqa: F401,F403

__all__ = atomic.__all__ + outputs.__all__ + inputs.__all__ + records.__all__ + jsonfiles.__all__ + formats.__all__
