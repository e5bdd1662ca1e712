"""Bundled data: the default sensor and example records."""

from __future__ import annotations

from importlib import resources

from creepcomp.io.jsonfiles import read_model
from creepcomp.model import CreepModel

__all__ = ["path", "default_sensor"]


def path(name: str):
    """Filesystem path of a bundled data file."""
    return resources.files(__name__).joinpath(name)


def default_sensor() -> CreepModel:
    """The bundled default sensor: one creep term, beta0 = 3 %, tau = 45 s."""
    return read_model(path("default_sensor.json"))
