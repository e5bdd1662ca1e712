"""Write the generated C of a fixed set of cases into a folder, to compare two versions.

A change of the firmware generator that should not change its output is checked by running
this with each version and comparing the folders::

    PYTHONPATH=/path/to/old/checkout/src python tools/dump_firmware.py /tmp/c-old
    python tools/dump_firmware.py /tmp/c-new
    diff -r /tmp/c-old /tmp/c-new

The cases cross 1-, 2- and 3-term models (relaxing terms, time constants from 1 ms to 1e7 s,
offsets), both methods, both precisions, three fixed rates and two ``max_interval`` steps,
three names and four full scales, and the naive float32 recursion; each case's header,
source, harness, bound and coefficients are written, and the messages of the cases the
generator refuses go to ``errors.json``.
"""

from __future__ import annotations

import argparse
import itertools
import json
from pathlib import Path

from creepcomp.digital.firmware import generate_firmware, naive_float32
from creepcomp.errors import InputError
from creepcomp.model import CreepModel

MODELS = {
    "m1": CreepModel(beta=(0.03,), tau=(45.0,), offset=0.0),
    "m1relax": CreepModel(beta=(-0.02,), tau=(10.0,), offset=1.5),
    "m2": CreepModel(beta=(0.03, 0.01), tau=(2.0, 300.0), offset=-0.25),
    "m2relax": CreepModel(beta=(0.05, -0.01), tau=(0.5, 50.0), offset=0.125),
    "m3": CreepModel(beta=(0.02, 0.015, 0.01), tau=(0.01, 3.0, 3000.0), offset=2.0),
    "m3wide": CreepModel(beta=(0.01, -0.005, 0.03), tau=(1e-3, 1.0, 1e6), offset=-7.5),
    "m1huge": CreepModel(beta=(0.04,), tau=(1e7,), offset=1e3),
}
RATES = (100.0, 1000.0, 7.5)
INTERVALS = (None, 0.04, 0.0005)
NAMES = ("creep", "sensor_a", "X1")
FULL_SCALES = (1.0, 3.3, 65536.0, 1e-3)


def _write(folder: Path, firmware, meta: dict) -> None:
    folder.mkdir()
    (folder / "h").write_text(firmware.header)
    (folder / "c").write_text(firmware.source)
    (folder / "harness.c").write_text(firmware.harness)
    (folder / "meta.json").write_text(json.dumps(meta, indent=1, default=str))


def dump(out: Path) -> tuple[int, int]:
    """Write every case into ``out``; returns (cases written, cases refused)."""
    refused = {}
    written = 0
    cases = itertools.product(MODELS.items(), ("subtractive", "supplemental"), ("float32", "q31"), RATES,
                              INTERVALS)
    for i, ((label, model), method, precision, rate, interval) in enumerate(cases):
        if interval is not None and rate != RATES[0]:
            continue
        name, full_scale = NAMES[i % len(NAMES)], FULL_SCALES[(i // 3) % len(FULL_SCALES)]
        case = f"{i:03d}_{label}_{method}_{precision}_{rate:g}_{interval}_{name}_{full_scale:g}"
        try:
            fw = generate_firmware(model, method, precision, rate, full_scale, name, max_interval=interval)
        except InputError as e:
            refused[case] = f"InputError: {e}"
            continue
        _write(out / case, fw, {"bound": fw.bound.to_dict(), "coef": fw.coefficients, "rate": fw.rate,
                                "max_interval": fw.max_interval})
        written += 1
    for i, ((label, model), method, rate) in enumerate(itertools.product(MODELS.items(),
                                                                        ("subtractive", "supplemental"),
                                                                        (100.0, 2000.0))):
        name, full_scale = NAMES[i % len(NAMES)], FULL_SCALES[i % len(FULL_SCALES)]
        case = f"naive{i:03d}_{label}_{method}_{rate:g}_{name}_{full_scale:g}"
        try:
            fw = naive_float32(model, method, rate, full_scale, name)
        except InputError as e:
            refused[case] = f"InputError: {e}"
            continue
        _write(out / case, fw, {"coef": fw.coefficients})
        written += 1
    (out / "errors.json").write_text(json.dumps(refused, indent=1))
    return written, len(refused)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("out", type=Path, help="a folder that does not exist yet, or an empty one")
    out = parser.parse_args().out
    if out.exists() and (not out.is_dir() or any(out.iterdir())):
        parser.error(f"{out}: exists and is not an empty folder")
    out.mkdir(parents=True, exist_ok=True)
    written, refused = dump(out)
    print(f"{written} cases written to {out}, {refused} refused (errors.json)")


if __name__ == "__main__":
    main()
