"""Bundled data, exposed by name: the default sensor and two example records.

``default_sensor()`` is the paper's accelerometer (one creep term); ``hidden_effect()`` a
synthetic force-sensor record that hides an effect the paper's model lacks (made by
:data:`creepcomp.synth.sensor.DEMO_SPEC`); ``built_network()`` a record of a built correction
network with a hidden fault and ``built_network_design()`` its nominal design (made by
:data:`creepcomp.synth.circuit.DEMO_CIRCUIT_SPEC`). ``path(name)`` gives any file's path.

Measured records of others, with their licences and sources beside them (``LICENSE`` and a
source note in ``real/insole/`` and ``real/wood/``; see ``docs/real-data.md``): one taxel of
each of two capacitive pressure insoles in an air chamber (:func:`insole_left_steps`,
:func:`insole_right_staircase`; BSD-3-Clause) and tensile creep of spruce slices at two load
levels (:func:`wood_creep`, :func:`wood_specimens`; MIT).
"""

from __future__ import annotations

from importlib import resources

from creepcomp.errors import InputError
from creepcomp.io.jsonfiles import Design, read_design, read_model
from creepcomp.io.records import Record, read_record
from creepcomp.model import CreepModel

__all__ = ["path", "default_sensor", "hidden_effect", "built_network", "built_network_design",
           "insole_left_steps", "insole_right_staircase", "WOOD_SPECIMENS", "wood_specimens",
           "wood_creep"]

#: The shipped wood specimens (90 % RH) by nominal loading degree; the first of each is the
#: default of :func:`wood_creep` (the longest record at that level).
WOOD_SPECIMENS = {
    0.3: ("1-mLR2-5-10", "1-mLR2-10-43", "1-mLR2-2-24", "1-mLR2-13-12", "1-mLR2-13-10"),
    0.5: ("1-mLR2-14-13", "1-mLR2-13-9", "1-mLR2-13-18", "1-mLR2-14-14", "1-mLR2-14-15"),
}


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


def _read_gz(name: str) -> Record:
    from creepcomp.io.formats import read_any

    with resources.as_file(path(name)) as p:
        return read_any(p)


def insole_left_steps() -> Record:
    """Left insole, taxel 128: counts (falling under load) on a pressure staircase up and down (bar)."""
    return _read_gz("real/insole/left_steps_taxel128.csv.gz")


def insole_right_staircase() -> Record:
    """Right insole, taxel 123: counts on ~0.2 bar steps held 15-30 s, up to 2.3 bar and back."""
    return _read_gz("real/insole/right_staircase_taxel123.csv.gz")


def wood_specimens(level: float | None = None) -> list[str]:
    """Names of the shipped wood specimens, all or at one nominal loading degree (0.3 or 0.5)."""
    if level is None:
        return [s for names in WOOD_SPECIMENS.values() for s in names]
    return list(WOOD_SPECIMENS[_wood_level(level)])


def _wood_level(level: float) -> float:
    for known in WOOD_SPECIMENS:
        if abs(float(level) - known) < 1e-9:
            return known
    raise InputError(f"wood creep: loading degree {level} not shipped; use "
                     f"{' or '.join(str(k) for k in WOOD_SPECIMENS)}")


def wood_creep(level: float = 0.3, specimen: str | None = None) -> Record:
    """Tensile creep of a spruce LR slice at 90 % RH: strain under a stress step (MPa) at t = 0."""
    names = WOOD_SPECIMENS[_wood_level(level)]
    name = specimen or names[0]
    if name not in names:
        raise InputError(f"wood creep: no specimen '{name}' at loading degree {level}; "
                         f"shipped: {', '.join(names)}")
    return read_record(path(f"real/wood/LR_RH90_{name}.csv"))
