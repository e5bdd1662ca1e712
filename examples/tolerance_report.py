"""Tolerances of a design: Monte Carlo, worst case, sensitivity, and the HTML report.

The parts are 1 % resistors and a 5 % polyester capacitor (with the dielectric absorption
and leakage of polyester at 25 °C); the specification is OIML R60 class C3's creep limit,
0.0245 % of full scale, on the peak residual creep after a load step. The script prints the
distribution of the peak and final residual creep and of the sweep hysteresis (nominal,
p50, p95, p99, max), the yield against the specification, the worst case over the tolerance
box and where it lies, which part dominates the spread, and what a tighter part would buy;
then it writes ``tolerances.html`` into ``--out`` (histograms, sensitivity chart, tables).

Run it::

    python examples/tolerance_report.py --design examples-output/size_network/design.json
    python examples/tolerance_report.py          # the bundled default sensor, sized here

Without ``--design`` it sizes the bundled default sensor (beta0 = 3 %, tau = 45 s) by the
exact rule with E24/E6 parts. ``--fast`` draws 2 000 Monte Carlo samples instead of
100 000, uses 2 000 samples instead of 20 000 per sensitivity and tighter-part run, and
skips the ngspice spot-check of the first 20 samples.
"""

from __future__ import annotations

import argparse
import os
from pathlib import Path

os.environ.setdefault("MPLBACKEND", "Agg")  # the plots go to files

from creepcomp import Design, default_sensor, read_design, size
from creepcomp.units import format_percent
from creepcomp.report.tolerance import tolerance_report_html
from creepcomp.verify import Tolerance, ToleranceSpec, analyse

#: OIML R60 class C3: creep within 0.0245 % of full scale.
SPEC_LIMIT = 0.000245
PARTS = ToleranceSpec(resistor=Tolerance(0.01), capacitor=Tolerance(0.05), dielectric="polyester")
#: (Monte Carlo samples, samples per sensitivity run, ngspice spot-check samples).
FULL = (100_000, 20_000, 20)
FAST = (2_000, 2_000, 0)
SEED = 1


def load_design(path: Path | None) -> Design:
    """The design file at ``path``, or the default sensor sized by the exact rule."""
    if path is not None:
        return read_design(path)
    model = default_sensor()
    return Design(model, size(model).chosen)


def main(argv: list[str] | None = None) -> int:
    """Run the tolerance analysis, print its figures, write the HTML report."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--design", type=Path,
                        help="design file (default: the bundled default sensor, sized here)")
    parser.add_argument("--out", type=Path, default=Path("examples-output/tolerance_report"),
                        help="folder for tolerances.html")
    parser.add_argument("--fast", action="store_true",
                        help="2 000 samples, smaller sensitivity runs, no ngspice spot-check")
    args = parser.parse_args(argv)

    design = load_design(args.design)
    n, sensitivity_n, spot_check_n = FAST if args.fast else FULL
    report = analyse(design, PARTS, n, seed=SEED, metric="peak", limit=SPEC_LIMIT,
                     sensitivity_samples=sensitivity_n, spot_check_samples=spot_check_n)
    result = report.result
    print(f"design: {args.design or 'bundled default sensor, exact rule, E24/E6 parts'}")
    print(f"parts: resistors ±{100 * PARTS.resistor.rel:g} %, capacitors "
          f"±{100 * PARTS.capacitor.rel:g} % {PARTS.dielectric} (3 sigma); {result.n} samples, "
          f"seed {result.seed}, {result.seconds:.2f} s ({1e6 * result.seconds / result.n:.2f} µs "
          "per sample)")
    print(f"\n  {'(fractions of full scale)':<30}{'nominal':>12}{'p50':>12}{'p95':>12}"
          f"{'p99':>12}{'max':>12}")
    for metric, label in (("peak", "residual creep, peak"), ("final", "residual creep, final"),
                          ("hysteresis", "hysteresis")):
        figures = [report.nominal.get(metric)[0], *result.percentiles(metric).values()]
        print(f"  {label:<30}" + "".join(f"{format_percent(v):>12}" for v in figures))
    share, error = result.yield_against(SPEC_LIMIT, "peak")
    print(f"\nyield against peak residual creep <= {format_percent(SPEC_LIMIT)} (OIML R60 C3): "
          f"{100 * share:.2f} % (± {100 * error:.2f} %)")
    worst = report.worst
    print(f"worst case of the peak residual creep: {format_percent(worst.value)} at "
          + ", ".join(f"{k} = {v:.4g}" for k, v in worst.at.items()) + f" ({worst.method})")
    if report.sensitivities:
        print("share of the spread each factor explains alone: "
              + ", ".join(f"{s.factor} {100 * s.share:.1f} %" for s in report.sensitivities))
    for t in report.tightenings:
        print(f"{t.factor} at ±{100 * t.tolerance_to:.3g} %"
              + (f" {t.dielectric}" if t.dielectric else "")
              + f" (now ±{100 * t.tolerance_from:.3g} %): p99 of the peak from {format_percent(t.p99_from)} "
              f"to {format_percent(t.p99_to)}")
    check = report.spot_check
    if check is not None and "error" in check:
        print(f"no ngspice spot-check: {check['error']}")
    elif check is not None:
        print(f"ngspice spot-check: {check['n']} samples agree with the Monte Carlo engine to "
              f"{check['agreement_max_abs']:.2e} of the step")
    html = tolerance_report_html(report, args.out / "tolerances.html", design_file=args.design)
    print(f"\nreport written to {html}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
