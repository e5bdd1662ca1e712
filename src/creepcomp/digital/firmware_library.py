"""The generated corrector as an installable library (``creepcomp firmware --library DIR``):
Arduino's library format (``library.properties``, ``src/``, ``examples/``, the 1.5 layout of
the Arduino library specification) with PlatformIO's ``library.json`` beside it.

The examples read an HX711 with bogde's HX711 library and a NAU7802 with SparkFun's library,
the two converter libraries most sketches use, and correct each conversion.
"""

from __future__ import annotations

import json
from pathlib import Path

from creepcomp.errors import InputError

__all__ = ["LIBRARY_EXAMPLES", "library_contents", "library_files", "write_library"]

#: The examples: folder (and sketch) name, template, the converter library it needs.
LIBRARY_EXAMPLES = (("HX711Scale", "library_hx711.ino.j2", "HX711"),
                    ("NAU7802Scale", "library_nau7802.ino.j2",
                     "SparkFun Qwiic Scale NAU7802 Arduino Library"))


def _library_version(version: str) -> str:
    """The library's version: creepcomp's ``MAJOR.MINOR.PATCH`` (semantic versioning, which
    both formats ask for), ``0.0.0`` when unknown."""
    parts = version.split("+")[0].split(".")[:3]
    if len(parts) == 3 and all(p.isdigit() for p in parts):
        return ".".join(parts)
    return "0.0.0"


def library_contents(name: str) -> tuple[str, ...]:
    """The files of the library of the corrector named ``name``, relative to its folder."""
    return ("library.properties", "library.json", f"src/{name}.h", f"src/{name}.c",
            *(f"examples/{folder}/{folder}.ino" for folder, _, _ in LIBRARY_EXAMPLES))


def library_files(firmware) -> dict[str, str]:
    """The library's files (relative path -> text) for a generated corrector.

    Examples
    --------
    >>> from creepcomp.model import CreepModel
    >>> from creepcomp.digital.firmware import generate_firmware
    >>> fw = generate_firmware(CreepModel((0.01,), (5.0,), 1.0, 84210.0), rate=80.0,
    ...                        full_scale=8388608.0)
    >>> sorted(library_files(fw))[:3]
    ['examples/HX711Scale/HX711Scale.ino', 'examples/NAU7802Scale/NAU7802Scale.ino', 'library.json']
    """
    from creepcomp.digital.firmware import _render, _version

    if firmware.uses_double or firmware.irregular or firmware.extension is not None:
        raise InputError("--library: the library is of the fixed-rate corrector without an "
                         "extension map (its examples read a converter at a fixed rate, and a map "
                         "computed in double has no bound on an ATmega's 32-bit double); write "
                         "this corrector with -o DIR")
    version = _version()
    library = f"creepcomp_{firmware.name}"
    timing = f"{firmware.rate:.9g} samples/s"
    values = {"name": firmware.name, "NAME": firmware.name.upper(), "precision": firmware.precision,
              "temperature": firmware.temperature_range is not None, "timing": timing,
              "full_scale": f"{firmware.full_scale:.9g}", "offset": f"{firmware.model.offset:.9g}"}
    if firmware.maps is not None:
        transfer, window = firmware.model.transfer, firmware.maps.get("load_filter")
        values["maps"] = ("a static calibration" if firmware.model.is_static else "none"
                          if transfer is None else transfer.describe())
        if window is not None:
            values["maps"] += f"; a load filter, the mean of the last {window['samples']} loads"
    header, source = firmware.filenames
    files = {f"src/{header}": firmware.header, f"src/{source}": firmware.source,
             "library.properties": _render(
                 "library.properties.j2", library=library, library_version=_library_version(version),
                 version=version, name=firmware.name, terms=str(firmware.model.n_terms),
                 method=firmware.method, precision=firmware.precision, timing=timing,
                 full_scale=values["full_scale"], bound_fs=f"{firmware.bound.total_fs:.3e}")}
    for folder, template, _ in LIBRARY_EXAMPLES:
        files[f"examples/{folder}/{folder}.ino"] = _render(template, **values)
    files["library.json"] = json.dumps({
        "name": library, "version": _library_version(version),
        "description": "Removes the creep of an elastomer-based load sensor sample by sample, "
                       f"with a proven error bound ({firmware.bound.total_fs:.3e} of full scale).",
        "keywords": ["creep", "load cell", "HX711", "NAU7802"],
        "frameworks": ["arduino"], "platforms": "*", "headers": [header],
        "examples": [f"examples/{folder}/*.ino" for folder, _, _ in LIBRARY_EXAMPLES],
        "build": {"srcDir": "src"}}, indent=2) + "\n"
    return dict(sorted(files.items()))


def write_library(firmware, folder) -> list[Path]:
    """Write the library into ``folder`` (created if needed), each file atomically.

    Returns
    -------
    list of Path
        The files written.

    Examples
    --------
    >>> write_library(fw, "creep-library")  # doctest: +SKIP
    """
    from creepcomp.io.atomic import write_text_atomic

    folder = Path(folder)
    if folder.exists() and not folder.is_dir():
        raise InputError(f"--library {folder} exists and is not a folder")
    written = []
    for relative, text in library_files(firmware).items():
        path = folder / relative
        path.parent.mkdir(parents=True, exist_ok=True)
        written.append(write_text_atomic(path, text))
    return written
