"""Synthetic records with known hidden effects, for tests, the demo and benchmarks: of a sensor
(:mod:`~creepcomp.synth.sensor`, its load programs in :mod:`~creepcomp.synth.loads`, the effects
no diagnosis template describes in :mod:`~creepcomp.synth.untemplated`; every other hidden effect
is the generator side of a registered sensor effect), of the soft sensors people build, far from
linear (:mod:`~creepcomp.synth.soft`), and of a built correction network
(:mod:`~creepcomp.synth.circuit`), with the noise and detectability rules they share
(:mod:`~creepcomp.synth.common`)."""

from creepcomp.synth import common, sensor, circuit
from creepcomp.synth.common import *  # noqa: F401,F403
from creepcomp.synth.sensor import *  # noqa: F401,F403
from creepcomp.synth.circuit import *  # noqa: F401,F403

__all__ = common.__all__ + sensor.__all__ + circuit.__all__
