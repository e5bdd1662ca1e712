"""Make the trimmed copies of the licensed real data shipped in ``src/creepcomp/data/real/``.

Reads the originals from ``../shared/data`` (or the folder given) with the project's own
loaders (:mod:`creepcomp.io.insole`, :mod:`creepcomp.io.wood`) and writes:

- ``insole/left_steps_taxel128.csv.gz`` and ``insole/right_staircase_taxel<K>.csv.gz``: one
  taxel of each insole file, its two channels cut to a common length as the authors' code
  does (first ``min(N, M)`` rows), time relative to the first sample (the logger's timestamp
  of that sample is kept as metadata ``time_origin``), pressure and counts as in the file;
  gzip-compressed (mtime 0, so the bytes are reproducible).
- ``wood/LR_RH90_<specimen>.csv``: every LR specimen at 90 % RH (both load levels), time in
  seconds, the creep stress as a constant load, ``signal`` = creep strain + stress / E (the
  mean LR modulus at that humidity, see ``creepcomp.io.wood``), and the file's own
  ``creep_strain`` and ``creep_compliance`` columns unchanged; the header block as metadata.

Not run by the tests. Usage::

    PYTHONPATH=src python tools/trim_real_data.py [../shared/data]
"""

from __future__ import annotations

import gzip
import io
import sys
from pathlib import Path


from creepcomp.io.insole import rank_taxels, read_insole_file
from creepcomp.io.wood import read_wood_sheet, wood_record, wood_sheets

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "src" / "creepcomp" / "data" / "real"
LEFT = "left/experiment_Inf_15September_steps_1.mat"
RIGHT = "right/experiment_2September_allTaxels_dynamic_pink_good.mat"
WOOD = "LR_samples_results.xlsx"
HUMIDITY = 90


def write_gz(path: Path, text: str) -> None:
    buf = io.BytesIO()
    with gzip.GzipFile(filename="", mode="wb", fileobj=buf, mtime=0) as gz:
        gz.write(text.encode("utf-8"))
    path.write_bytes(buf.getvalue())


def insole_csv(shared: Path, name: str, taxel: int, out: Path) -> None:
    f = read_insole_file(shared / "insole" / name)
    counts = f.counts[:, taxel]
    lines = [f"# source: insole/{name} (ami-iit/paper_belli_2023_sensors_insole-calibration, "
             f"commit 34f0241, Data/), BSD-3-Clause, see LICENSE",
             f"# insole.taxel: {taxel} (column {taxel + 2} of experiment.C, counting from 0)",
             f"# insole.alignment: {f.alignment}",
             f"# time_origin: {f.time[0]:.6f} s (experiment.C timestamp of the first sample)",
             "# units.load: bar", "# units.signal: counts",
             "# insole.sign: the counts fall as the pressure rises: the gain is negative",
             "time,load,signal"]
    t = f.time - f.time[0]
    lines += [f"{a:.6f},{b:.6f},{c:.0f}" for a, b, c in zip(t, f.pressure, counts)]
    write_gz(out, "\n".join(lines) + "\n")
    print(f"{out.relative_to(ROOT)}: {len(t)} rows, {out.stat().st_size} bytes")


def main(shared: Path) -> None:
    right = read_insole_file(shared / "insole" / RIGHT)
    best = rank_taxels(right, top=5)
    print("right insole, taxels that follow the pressure best:",
          ", ".join(f"{r['taxel']} (r = {r['correlation']:.4f})" for r in best))
    insole_csv(shared, LEFT, 128, OUT / "insole" / "left_steps_taxel128.csv.gz")
    insole_csv(shared, RIGHT, best[0]["taxel"], OUT / "insole" / f"right_staircase_taxel{best[0]['taxel']}.csv.gz")
    for old in (OUT / "wood").glob("LR_RH*.csv"):
        old.unlink()
    for sheet in wood_sheets(shared / "wood" / WOOD):
        ws = read_wood_sheet(shared / "wood" / WOOD, sheet)
        if ws.header.get("Nominal RH [%]") != HUMIDITY:
            continue
        r = wood_record(ws)
        meta = {k: v for k, v in r.metadata.items()}
        lines = [f"# source: wood/{WOOD}, sheet {sheet} (alessiafe/Mesoscale-Creep-Evaluation-Routines, "
                 "commit 0863aaf), MIT, see LICENSE"]
        lines += [f"# {k}: {v}" for k, v in meta.items()]
        lines.append("time,load,signal,creep_strain,creep_compliance")
        comp = ws.columns["Creep Compliance [MPa^-1]"]
        creep = ws.columns["Creep Strain [-]"]
        lines += [f"{a!r},{b!r},{c!r},{d!r},{e!r}" for a, b, c, d, e in
                  zip(r.time.tolist(), r.load.tolist(), r.signal.tolist(), creep.tolist(), comp.tolist())]
        out = OUT / "wood" / f"LR_RH{HUMIDITY}_{sheet}.csv"
        out.write_text("\n".join(lines) + "\n", encoding="utf-8")
        print(f"{out.relative_to(ROOT)}: {len(r)} rows, loading degree "
              f"{ws.header.get('Nominal Loading Degree [-]')}, {out.stat().st_size} bytes")


if __name__ == "__main__":
    main(Path(sys.argv[1]) if len(sys.argv) > 1 else ROOT.parent / "shared" / "data")
