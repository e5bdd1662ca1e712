"""Fit and diagnose measured creep of spruce slices under a constant tensile stress.

The records ship with creepcomp (``creepcomp.data.wood_creep(level)``: LR slices at 90 %
relative humidity, nominal loading degree 0.3 or 0.5 of strength; 10 specimens), trimmed
from the data of Ferrara and Wittel (MIT; licence and source beside the files). A material
test, not a sensor record: ``load`` is the creep stress (MPa), a step at t = 0, so every fit
is given ``load_step_at=0``; ``signal`` is the strain, the file's creep strain plus the
instantaneous strain ``stress / E`` (E: the authors' mean modulus at that humidity, because
the files' creep strain starts at 0; see ``docs/record-format.md``).

The script fits every shipped specimen (terms by evidence) and prints beta, tau and the
creep compliance after 50 h at both load levels (is the creep proportional to the load?),
then diagnoses the default specimen of each level. It writes into ``--out``:
``wood-<level>-fit.png`` and ``wood-<level>/report.html`` with ``diagnosis.json`` and models.

Run it::

    python examples/real_wood.py

``--fast`` fits only the two default specimens (the whole run takes a few seconds anyway).
"""

from __future__ import annotations

import argparse
import os
from pathlib import Path

import numpy as np

os.environ.setdefault("MPLBACKEND", "Agg")  # the plots go to files

from creepcomp import data, diagnose
from creepcomp.errors import InputError
from creepcomp.fit import fit_prony, prepare, term_table
from creepcomp.fit.noise import none_statement
from creepcomp.report.common import save_axes
from creepcomp.report.diagnosis import plot_fit, write_report
from creepcomp.units import format_parameter, format_percent, format_quantity

AT = 50 * 3600.0   # creep compliance compared at 50 h (every shipped test lasts longer)


def creep_compliance(prony, t: float) -> float:
    """The fitted creep strain at ``t`` after the step, per unit stress (1/MPa)."""
    gain = prony.fit.estimate(lambda v: v["gain"])[0]
    return float(sum(gain * tt["beta"] * -np.expm1(-t / tt["tau"]) for tt in term_table(prony.fit)))


def main(argv: list[str] | None = None) -> int:
    """Fit every specimen, compare the load levels, diagnose one specimen per level."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("examples-output/real_wood"),
                        help="folder for the plots and reports")
    parser.add_argument("--fast", action="store_true", help="fit only the default specimens")
    args = parser.parse_args(argv)
    print("creep compliance J_c(50 h) = fitted creep strain at 50 h / stress; load step at t = 0")
    for level in (0.3, 0.5):
        names = data.wood_specimens(level)[:1] if args.fast else data.wood_specimens(level)
        for name in names:
            r = data.wood_creep(level, name)
            head = f"  {level} {name}: {float(r.load[0]):.1f} MPa, {len(r)} samples over {r.duration / 3600:.0f} h"
            try:
                prony = fit_prony(prepare(r, load_step_at=0.0))
            except InputError as exc:
                print(f"{head}: not fitted ({str(exc).split(': ', 1)[-1]})")
                continue
            terms = term_table(prony.fit)
            print(f"{head}: beta0 = {format_percent(sum(t['beta'] for t in terms), 3)} over "
                  + ", ".join(f"tau = {format_quantity(t['tau'], 's')}" for t in terms)
                  + f"; J_c(50 h) = {creep_compliance(prony, AT):.3g} 1/MPa; residual "
                    f"{format_percent(prony.fit.residual_rms / prony.data.signal_scale)} of range")
    for level in (0.3, 0.5):
        r = data.wood_creep(level)
        prony = fit_prony(prepare(r, load_step_at=0.0))
        save_axes(plot_fit(prony.data, prony.fit, record=r), args.out / f"wood-{level}-fit.png")
        result = diagnose(r, load_step_at=0.0)
        d = result.to_dict()
        b, e, g = d["baseline"], d["extended"], d["gain"]
        print(f"\ndiagnose {level} ({r.metadata.get('wood.Sample', '')}): cause: {d['cause']}")
        for f in result.findings:
            print("  " + f.effect + ": " + "; ".join(f"{k} = {format_parameter(k, v)}"
                                                   for k, v in f.parameters.items()))
            if f.note:
                print(f"    note: {f.note}")
        print(f"  baseline residual RMS {b['residual_rms']:.3g} {r.unit('signal')} "
              f"({format_percent(b['residual_rms_relative'])} of range), extended {e['residual_rms']:.3g}; "
              f"held-out RMS ratio {g['heldout_rms_ratio']:.3g}")
        print(f"  noise floor {d['noise_floor']:.3g} {r.unit('signal')} from {d['noise_floor_windows']} windows"
              + (" (a rough estimate)" if result.floor.rough else "")
              + f"; misfit ratio {b['misfit_ratio']:.3g} -> {e['misfit_ratio']:.3g}")
        if not result.findings:
            print(f"  {none_statement(result.floor)}")
        paths = write_report(result, args.out / f"wood-{level}", {"signal": r.unit("signal"), "load": r.unit("load")})
        print(f"  written: {args.out / f'wood-{level}-fit.png'}, {paths['report']}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
