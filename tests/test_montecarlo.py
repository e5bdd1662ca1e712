import json

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from creepcomp.verify.montecarlo import run_monte_carlo, spot_check
from creepcomp.verify.sensitivities import first_order_index
from creepcomp.verify.tolerance_analysis import analyse
from creepcomp.verify.tolerances import DIELECTRICS, Tolerance, ToleranceSpec, draw, factors
from creepcomp.verify.variants import evaluate, variant
from creepcomp.verify.worstcase import worst_case
from creepcomp.errors import InputError
from creepcomp.io.jsonfiles import Design, write_design
from creepcomp.lti import cascade_lags, cascade_step_arrays
from creepcomp.model import CreepModel
from creepcomp.network import Cell, Network
from creepcomp.analog.quality import predict
from creepcomp.analog.sizing import ideal_network

MODEL = CreepModel.voigt(0.03, 45.0)
DESIGN = Design(MODEL, Network((Cell(3e6, 15e-6),), 1e8))
PERIOD = 2 * np.pi * 45.0


@given(st.integers(0, 2**31), st.sampled_from([None, "polyester", "x7r"]))
@settings(max_examples=12)
def test_engine_matches_python_control_sample_by_sample(seed, dielectric):
    spec = ToleranceSpec(capacitor=Tolerance(0.1), dielectric=dielectric, beta=Tolerance(0.1),
                         tau=Tolerance(0.1), source_resistance=(0, 1e5), load_resistance=(1e8, 1e11))
    box = factors(DESIGN, spec)
    values = draw(box, 3, seed)
    got = evaluate(DESIGN, values, PERIOD, dielectric)
    insulation = DIELECTRICS[dielectric].insulation_time(25.0) if dielectric else None
    for i in range(3):
        c = values["C1"][i]
        extra = {}
        if dielectric:
            c_da = values["C1.absorption"][i] * c
            extra = dict(leakage=insulation / c, absorption_R=values["C1.absorption_tau"][i] / c_da,
                         absorption_C=c_da)
        net = Network((Cell(values["R1"][i], c, **extra),), values["R2"][i], (),
                      values["source_resistance"][i], values["load_resistance"][i])
        model = MODEL.with_terms([values["beta[0]"][i]], [values["tau[0]"][i]])
        q = predict(model, net, PERIOD)
        assert got.peak[i] == pytest.approx(q.residual_creep_peak, rel=1e-4, abs=1e-12)
        assert got.final[i] == pytest.approx(q.residual_creep_final, rel=1e-8, abs=1e-13)
        assert got.hysteresis[i] == pytest.approx(q.hysteresis, rel=1e-4, abs=1e-12)


def test_cascade_lags_step_equals_the_stable_closed_form():
    net = ideal_network(MODEL, "paper", 10e-6)           # coincident poles: the hard case
    h = net.lag_expansion()
    g = MODEL.lag_expansion()
    D, R, q = cascade_lags(1.0, [g.gains], [g.taus], h.direct, [h.gains], [h.taus])
    t = np.linspace(0, 900, 301)
    fast = D[0] + np.sum(R[0][:, None] * -np.expm1(-t[None, :] / q[0][:, None]), axis=0)
    stable = cascade_step_arrays(1.0, g.gains, g.taus, h.direct, h.gains, h.taus, t)
    np.testing.assert_allclose(fast, stable, atol=1e-9)


def test_same_seed_same_numbers_and_workers_do_not_matter():
    spec = ToleranceSpec(dielectric="polyester")
    a = run_monte_carlo(DESIGN, spec, 30_000, seed=7, chunk=7_000, workers=1)
    b = run_monte_carlo(DESIGN, spec, 30_000, seed=7, chunk=10_000, workers=2)
    np.testing.assert_array_equal(a.metrics.peak, b.metrics.peak)
    assert a.percentiles() == b.percentiles()


def test_different_seeds_agree_within_sampling_error():
    spec = ToleranceSpec()
    n = 40_000
    runs = [run_monte_carlo(DESIGN, spec, n, seed=s, workers=1) for s in (1, 2)]
    for q in (50, 95, 99):
        vals = [np.percentile(r.metrics.peak, q) for r in runs]
        # standard error of a quantile: sqrt(p(1-p)/n) / density, density from the sample
        p = q / 100
        v = runs[0].metrics.peak
        width = np.percentile(v, min(q + 1, 99.9)) - np.percentile(v, q - 1)
        density = (min(q + 1, 99.9) - (q - 1)) / 100 / width
        se = np.sqrt(p * (1 - p) / n) / density
        assert abs(vals[0] - vals[1]) < 5 * np.sqrt(2) * se
        assert vals[0] != vals[1]


def test_worst_case_bounds_every_sample_and_finds_the_corner():
    spec = ToleranceSpec(resistor=Tolerance(0.0), capacitor=Tolerance(0.05, "uniform"))
    wc = worst_case(DESIGN, spec)
    corners = evaluate(DESIGN, {"C1": np.array([15e-6 * 0.95, 15e-6 * 1.05])}, PERIOD).peak
    assert wc.value == pytest.approx(corners.max(), rel=1e-9)
    spec = ToleranceSpec(dielectric="polyester", beta=Tolerance(0.05))
    wc = worst_case(DESIGN, spec)
    sampled = run_monte_carlo(DESIGN, spec, 20_000, seed=3, workers=1).metrics.peak
    assert wc.value >= sampled.max()


def test_capacitor_dominates_with_polyester_and_a_tighter_one_helps():
    spec = ToleranceSpec(resistor=Tolerance(0.01), capacitor=Tolerance(0.05), dielectric="polyester")
    rep = analyse(DESIGN, spec, 40_000, seed=1, limit=0.000245, sensitivity_samples=5_000, workers=1)
    assert rep.sensitivities[0].factor == "C1"
    c1 = next(t for t in rep.tightenings if t.factor == "C1")
    assert c1.p99_to < c1.p99_from and c1.dielectric == "polypropylene"
    better = analyse(DESIGN, ToleranceSpec(capacitor=Tolerance(0.01), dielectric="polypropylene"),
                     40_000, seed=1, limit=0.000245, sensitivity_samples=0, worst=False, workers=1)
    assert better.result.yield_against(0.000245)[0] > rep.result.yield_against(0.000245)[0]


def test_first_order_index_finds_the_driver():
    rng = np.random.default_rng(0)
    x1, x2 = rng.normal(size=(2, 50_000))
    y = 3 * x1 + 0.5 * x2 ** 2
    assert first_order_index(x1, y) == pytest.approx(9 / (9 + 0.5), abs=0.02)
    assert first_order_index(x2, y) == pytest.approx(0.5 / (9 + 0.5), abs=0.02)
    assert first_order_index(rng.normal(size=50_000), y) < 0.005


@pytest.mark.parametrize("kwargs,match", [
    (dict(dielectric="paper"), "dielectric 'paper'"),
    (dict(load_resistance=(0, 1e9)), "positive"),
    (dict(parts={"C9": Tolerance(0.01)}), "no part named C9"),
])
def test_bad_specs(kwargs, match):
    with pytest.raises(InputError, match=match):
        factors(DESIGN, ToleranceSpec(**kwargs))


def test_cli_mc_json_contract_and_report(run_cli, tmp_path):
    design = write_design(tmp_path / "d.json", DESIGN)
    report = tmp_path / "r.html"
    status, out, err = run_cli("mc", design, "--n", "20000", "--seed", "3", "--dielectric", "polyester",
                               "--cap-tol", "5%", "--spec", "0.0245%", "--sensitivity-n", "2000",
                               "--report", report, "--json")
    assert status == 0, err
    data = json.loads(out)
    assert data["n"] == 20000 and data["seconds"] > 0
    assert set(data["residual_creep_peak"]) == {"p50", "p95", "p99", "max"}
    assert 0 < data["spec"]["yield"] < 1 and data["sensitivity"][0]["factor"] == "C1"
    assert data["worst_case"]["value"] >= data["residual_creep_peak"]["max"]
    html = report.read_text()
    assert html.count("data:image/png;base64,") == 2 and "Yield" in html
    status, out, err = run_cli("mc", design, "--n", "5000", "--tol", "C1=1%", "--sensitivity-n", "0",
                               "--no-worst-case")
    assert status == 0 and "yield against" not in out and "Distribution" in out


@pytest.mark.parametrize("args,needle", [
    (["--n", "0"], "--n 0"), (["--dielectric", "mica"], "--dielectric"), (["--tol", "C1"], "PART=TOL"),
    (["--res-tol", "-1%"], "--res-tol"), (["--dist", "cauchy"], "--dist"), (["--metric", "x"], "metric 'x'"),
])
def test_cli_mc_bad_input(run_cli, tmp_path, args, needle):
    design = write_design(tmp_path / "d.json", DESIGN)
    status, out, err = run_cli("mc", design, *args)
    assert status == 2 and needle in err and len(err.strip().splitlines()) == 1


def test_ngspice_spot_check_agrees_with_the_engine():
    spec = ToleranceSpec(dielectric="polyester", beta=Tolerance(0.05), load_resistance=(1e9, 1e11))
    result = run_monte_carlo(DESIGN, spec, 1000, seed=5, workers=1)
    check = spot_check(result, n=5, points=200)
    assert check["n"] == 5 and check["agreement_max_abs"] < 1e-6
    one = variant(DESIGN, result.values, 2, "polyester")
    assert one.network.cells[0].has_absorption and one.network.load_resistance == result.values["load_resistance"][2]
    assert evaluate(DESIGN, {k: v[2:3] for k, v in result.values.items()}, PERIOD, "polyester").peak[0] == \
        pytest.approx(predict(one.model, one.network, PERIOD).residual_creep_peak, rel=1e-4)


def test_a_run_that_fits_in_one_block_is_exact_and_blocks_stream_within_their_resolution():
    from creepcomp.verify.montecarlo import block_seed

    spec = ToleranceSpec(dielectric="polyester")
    whole = run_monte_carlo(DESIGN, spec, 12_000, seed=5, workers=1)
    one_block = run_monte_carlo(DESIGN, spec, 12_000, seed=5, workers=1, block=12_000)
    assert whole.kept == whole.n == 12_000 and whole.resolution() == 0
    assert one_block.percentiles() == whole.percentiles()
    # the same as the samples drawn in one go from the seed (today's numbers)
    alone = evaluate(DESIGN, draw(whole.box, 12_000, 5), whole.sweep_period, "polyester").peak
    np.testing.assert_array_equal(whole.metrics.peak, alone)

    limit = 3e-4
    streamed = run_monte_carlo(DESIGN, spec, 12_000, seed=5, workers=1, block=2_500, limit=limit)
    assert streamed.n == 12_000 and streamed.kept == 2_500 and streamed.resolution() > 0
    every = np.concatenate([evaluate(DESIGN, draw(streamed.box, size, block_seed(5, i)),
                                     streamed.sweep_period, "polyester").peak
                            for i, size in enumerate((2_500,) * 4 + (2_000,))])
    got = streamed.percentiles()
    assert got["max"] == every.max()
    for q in (50, 95, 99):
        exact = np.percentile(every, q)
        gap = np.diff(np.sort(every)).max()       # linear interpolation between two samples
        assert abs(got[f"p{q}"] - exact) <= streamed.resolution() + gap
        assert abs(got[f"p{q}"] - exact) < 1e-3 * exact
    assert streamed.yield_against(limit)[0] == np.mean(every <= limit)
    with pytest.raises(InputError, match="needs the Monte Carlo run with that limit"):
        streamed.yield_against(2 * limit)


def test_streaming_percentiles_stay_within_one_bin_as_the_range_grows():
    from creepcomp.verify.montecarlo import StreamingPercentiles

    x = np.random.default_rng(1).lognormal(size=400_000)
    x[-1] = -50.0                                   # late values far outside the first blocks
    x[-2] = 1e4
    stream = StreamingPercentiles(bins=1024)
    for lo in range(0, len(x), 50_000):
        stream.add(x[lo:lo + 50_000])
    assert not stream.exact and stream.n == len(x) and (stream.min, stream.max) == (-50.0, 1e4)
    s = np.sort(x)
    for q in (1, 50, 95, 99, 99.9):
        rank = q / 100 * (len(x) - 1)
        lo, hi = s[int(np.floor(rank))], s[int(np.ceil(rank))]
        assert lo - stream.resolution <= stream.percentile(q) <= hi + stream.resolution


def test_html_tables_give_numbers_with_their_units(tmp_path):
    from creepcomp.report.common import format_cell, format_named
    from creepcomp.report.tolerance import tolerance_report_html

    assert format_named("R2", 99000.0) == "99 kΩ" and format_named("C1", 0.00126) == "1.26 mF"
    assert f"{format_named('tau', 150.4)} ± {format_named('tau', 0.5257)}" == "150.4 s ± 525.7 ms"
    assert format_named("beta[0]", 0.03) == "3 %" and format_cell(float("nan"), "Ω") == "–"
    rep = analyse(DESIGN, ToleranceSpec(load_resistance=(1e8, 1e11)), 3_000, sensitivity_samples=0,
                  worst=True, spot_check_samples=1)
    page = tolerance_report_html(rep, tmp_path / "r.html").read_text()
    box = page[page.index("Tolerance box"):]
    assert "<td>R1</td><td>3 MΩ</td>" in box and "<td>C1</td><td>15 µF</td>" in box
    assert "<td>load_resistance</td><td>" in box and "GΩ" in box
    worst = page[page.index("Worst case"):page.index("Tolerance box")]
    assert "Ω</td>" in worst and "F</td>" in worst
    if "No ngspice" not in page:
        assert "<td>time per ngspice transient</td><td>" in page and "s</td>" in page
