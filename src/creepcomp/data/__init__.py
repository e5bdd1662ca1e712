"""Bundled data, exposed by name: the default sensor and two example records.

``default_sensor()`` is the paper's accelerometer (one creep term); ``hidden_effect()`` a
synthetic force-sensor record that hides an effect the paper's model lacks (made by
:data:`creepcomp.synth.sensor.DEMO_SPEC`); ``built_network()`` a record of a built correction
network with a hidden fault and ``built_network_design()`` its nominal design (made by
:data:`creepcomp.synth.circuit.DEMO_CIRCUIT_SPEC`). ``path(name)`` gives any file's path.
"""

from __future__ import annotations

from importlib import resources

from creepcomp.io.jsonfiles import Design, read_design, read_model
from creepcomp.io.records import Record, read_record
from creepcomp.model import CreepModel

__all__ = ["path", "default_sensor", "hidden_effect", "built_network", "built_network_design"]


def path(name: str):
    """Filesystem path of a bundled data file."""
    return resources.files(__name__).joinpath(name)


def default_sensor() -> CreepModel:
    """The bundled default sensor: one creep term, beta0 = 3 %, tau = 45 s."""
    return read_model(path("default_sensor.json"))


def hidden_effect() -> Record:
    """A force sensor (V per N) on a staircase of steps, whose recovery is slower than its creep."""
    return read_record(path("hidden_effect.csv"))


def built_network() -> Record:
    """A sensor and its built correction network (``signal`` and ``corrected``) with a hidden fault."""
    return read_record(path("built_network.csv"))


def built_network_design() -> Design:
    """The nominal design of the network of :func:`built_network`."""
    return read_design(path("built_network.design.json"))
