"""Digital creep correction of sampled signals: the recursive correctors (``correctors``), the
paper's literal formulas (``paper_methods``, for comparison) and its test scenarios
(``scenarios``)."""

from creepcomp.digital import correctors, paper_methods, scenarios
from creepcomp.digital.correctors import *  # noqa: F401,F403
from creepcomp.digital.paper_methods import *  # noqa: F401,F403
from creepcomp.digital.scenarios import *  # noqa: F401,F403

__all__ = correctors.__all__ + paper_methods.__all__ + scenarios.__all__
