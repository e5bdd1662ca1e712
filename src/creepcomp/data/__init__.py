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

Every bundled record is also in a registry by name (:data:`RECORDS`, :func:`records`,
:func:`record`), which ``creepcomp data list`` prints, and :func:`export` writes one as a CSV
file into a folder (``creepcomp data export NAME [DIR]``), with the files it names and its
licence, so that the command line can work on it anywhere.
"""

from __future__ import annotations

import gzip
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import Callable

from creepcomp.errors import InputError
from creepcomp.io.jsonfiles import Design, read_design, read_model
from creepcomp.io.records import Record, read_record
from creepcomp.model import CreepModel

__all__ = ["path", "default_sensor", "hidden_effect", "built_network", "built_network_design",
           "insole_left_steps", "insole_right_staircase", "WOOD_SPECIMENS", "wood_specimens",
           "wood_creep", "BundledRecord", "RECORDS", "records", "record", "export"]

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


#: The licence of the records this project made (the project's own).
PROJECT_LICENCE = "MIT"


@dataclass(frozen=True)
class BundledRecord:
    """A record shipped with the package, by name.

    Attributes
    ----------
    name : str
        The name ``creepcomp data export`` and :func:`record` take.
    description : str
        What it is, in one line.
    licence : str
        Its licence (``licence_file`` holds the text of another's).
    file : str
        The record's file in the package (:func:`path`); ``.gz``: compressed.
    read : callable
        Reads it (:func:`hidden_effect`, ...).
    companions : tuple of str
        Files in the package the record names (its design), exported beside it.
    licence_file : str or None
        The licence's text in the package, exported beside the record as ``NAME.LICENSE``.
    """

    name: str
    description: str
    licence: str
    file: str
    read: Callable[[], Record]
    companions: tuple[str, ...] = ()
    licence_file: str | None = None

    @property
    def csv_name(self) -> str:
        """The exported record's file name: ``NAME.csv``, or the name its companions expect."""
        return Path(self.file).name if self.companions else f"{self.name}.csv"

    def export_names(self) -> list[str]:
        """The files :func:`export` writes, record first."""
        names = [self.csv_name] + [Path(c).name for c in self.companions]
        return names + ([f"{self.name}.LICENSE"] if self.licence_file else [])

    def csv_bytes(self) -> bytes:
        """The record's CSV text as shipped (decompressed when the package holds it gzipped)."""
        data = path(self.file).read_bytes()
        return gzip.decompress(data) if self.file.endswith(".gz") else data


def _wood_entry(level: float, specimen: str) -> BundledRecord:
    return BundledRecord(
        f"wood_{specimen}", f"spruce slice creep test, loading {level} (MPa)", "MIT",
        f"real/wood/LR_RH90_{specimen}.csv", lambda: wood_creep(level, specimen),
        licence_file="real/wood/LICENSE")


#: Every bundled record by name, the synthetic ones first.
RECORDS: dict[str, BundledRecord] = {entry.name: entry for entry in (
    BundledRecord("hidden_effect", "synthetic force sensor (N, V), a hidden effect",
                  PROJECT_LICENCE, "hidden_effect.csv",
                  hidden_effect),
    BundledRecord("built_network", "synthetic sensor and built network, one fault",
                  PROJECT_LICENCE,
                  "built_network.csv", built_network, companions=("built_network.design.json",)),
    BundledRecord("insole_left_steps", "pressure insole taxel, staircase (bar, counts)",
                  "BSD-3-Clause",
                  "real/insole/left_steps_taxel128.csv.gz", insole_left_steps,
                  licence_file="real/insole/LICENSE"),
    BundledRecord("insole_right_staircase", "pressure insole taxel, 0.2 bar steps",
                  "BSD-3-Clause",
                  "real/insole/right_staircase_taxel123.csv.gz", insole_right_staircase,
                  licence_file="real/insole/LICENSE"),
    *(_wood_entry(level, specimen) for level, names in WOOD_SPECIMENS.items() for specimen in names),
)}


def records() -> list[BundledRecord]:
    """The bundled records (:data:`RECORDS`), the synthetic ones first.

    Examples
    --------
    >>> from creepcomp import data
    >>> [r.name for r in data.records()][:3]
    ['hidden_effect', 'built_network', 'insole_left_steps']
    >>> len(data.record("hidden_effect").read())
    3001
    """
    return list(RECORDS.values())


def record(name: str) -> BundledRecord:
    """The bundled record called ``name``; an InputError naming the known ones otherwise."""
    try:
        return RECORDS[name]
    except KeyError:
        raise InputError(f"no bundled record '{name}'; bundled: {', '.join(RECORDS)}") from None


def export(name: str, folder: str | Path = ".", force: bool = False) -> list[Path]:
    """Write a bundled record as a CSV file into ``folder``, with the files it names (a
    network's design) and another's licence text (``NAME.LICENSE``).

    Parameters
    ----------
    name : str
        A name of :data:`RECORDS`.
    folder : str or Path
        Made when missing (its parent must exist).
    force : bool
        Replace files of the same names; without it an existing file is never replaced.

    Returns
    -------
    list of Path
        The files written, the record first.

    Raises
    ------
    InputError
        An unknown name, a folder that cannot take the files, or a file there already
        (without ``force``).

    Examples
    --------
    >>> import tempfile
    >>> from creepcomp import data, read_record
    >>> folder = tempfile.mkdtemp()
    >>> [p.name for p in data.export("built_network", folder)]
    ['built_network.csv', 'built_network.design.json']
    >>> len(read_record(data.export("hidden_effect", folder)[0]))
    3001
    """
    from creepcomp.io.atomic import write_bytes_atomic
    from creepcomp.io.outputs import check_output_dir, lock_output

    entry = record(name)
    out = check_output_dir(folder, "DIR", contents=entry.export_names())
    lock_output(out, "DIR")
    targets = [out / n for n in entry.export_names()]
    there = [t for t in targets if t.exists() or t.is_symlink()]
    if there and not force:
        raise InputError(f"{there[0]}: exists already; choose another folder, or replace it "
                         "(--force; force=True from Python)")
    contents = [entry.csv_bytes()] + [path(c).read_bytes() for c in entry.companions]
    if entry.licence_file:
        contents.append(path(entry.licence_file).read_bytes())
    out.mkdir(parents=True, exist_ok=True)
    return [write_bytes_atomic(t, data) for t, data in zip(targets, contents)]
