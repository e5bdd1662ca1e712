"""Monte Carlo over temperature: TCs drawn per part, thermistors, lot correlation, every unit
at each temperature in one batch."""

import json

import numpy as np
import pytest

from creepcomp.analog.parts import PartsPlan, ThermistorUse, network_at, ntc_resistance
from creepcomp.analog.quality import predict
from creepcomp.io.jsonfiles import Design, write_design
from creepcomp.model import CreepModel
from creepcomp.network import Cell, Network
from creepcomp.temperature import TemperatureLaw
from creepcomp.verify.montecarlo import nominal_metrics, run_monte_carlo
from creepcomp.verify.tolerances import OverTemperature, Tolerance, ToleranceSpec, draw, factors
from creepcomp.verify.variants import variant

MODEL = CreepModel((0.03,), (45.0,), temperature=TemperatureLaw.arrhenius(43_000.0, 20.0))
DESIGN = Design(MODEL, Network((Cell(3e6, 15e-6),), 1e8))
PERIOD = 2 * np.pi * 45.0
TEMPS = (-10.0, 20.0, 40.0)
AT_20 = float(ntc_resistance(1.0, 4250.0, 20.0))
TRACKING = PartsPlan(thermistors={"R1": ThermistorUse("NTC", 3e6 / AT_20, 4250.0, tolerance=0.01),
                                  "R2": ThermistorUse("NTC", 1e8 / AT_20, 4250.0, series=1e3)})


def _spec(temps=TEMPS, plan=PartsPlan(), rho=0.0, dielectric=None):
    return ToleranceSpec(capacitor=Tolerance(0.01), dielectric=dielectric,
                         over_temperature=OverTemperature(temps, plan, rho))


@pytest.mark.parametrize("plan", [PartsPlan(), TRACKING], ids=["fixed", "tracking"])
def test_nominal_at_each_temperature_is_the_design_at_that_temperature(plan):
    nominal = nominal_metrics(DESIGN, _spec(plan=plan), PERIOD)
    for k, t in enumerate(TEMPS):
        exact = predict(MODEL.at_temperature(t), network_at(DESIGN.network, plan, t), PERIOD)
        assert nominal.per_temperature.peak[0, k] == pytest.approx(exact.residual_creep_peak, rel=1e-9)
        assert nominal.per_temperature.hysteresis[0, k] == pytest.approx(exact.hysteresis, rel=1e-4)
    assert nominal.peak[0] == nominal.per_temperature.peak[0].max()


@pytest.mark.parametrize("dielectric", [None, "polyester"])
def test_batched_temperatures_are_the_single_temperature_runs(dielectric):
    together = run_monte_carlo(DESIGN, _spec(dielectric=dielectric), 3000, seed=4, workers=1)
    for k, t in enumerate(TEMPS):
        alone = run_monte_carlo(DESIGN, _spec((t,), dielectric=dielectric), 3000, seed=4, workers=1)
        np.testing.assert_array_equal(together.metrics.per_temperature.peak[:, k], alone.metrics.peak)
        np.testing.assert_array_equal(together.metrics.per_temperature.final[:, k], alone.metrics.final)
    per = together.metrics.per_temperature
    np.testing.assert_array_equal(together.metrics.peak, per.peak.max(axis=1))
    assert sum(together.worst_temperature_counts) == 3000
    # a sample as a design of its own, at one temperature, gives the batch's figure
    at = OverTemperature((40.0,), PartsPlan())
    one = variant(DESIGN, together.values, 7, dielectric, 25.0, at)
    assert one.model.temperature is None and one.model.tau[0] == pytest.approx(MODEL.at_temperature(40.0).tau[0])
    assert per.peak[7, 2] == pytest.approx(predict(one.model, one.network, PERIOD).residual_creep_peak,
                                            rel=1e-6)


def test_each_part_draws_its_own_tc_and_thermistors_their_r25_and_b():
    names = [f.name for f in factors(DESIGN, _spec(plan=TRACKING))]
    assert names == ["R1.R25", "C1", "R2.R25", "R1.B", "C1.tc", "R2.B"]
    # a thermistor's own tolerance is its R25's, unless the part is given one (a tighter part)
    spec = ToleranceSpec(parts={"R1": Tolerance(0.001)},
                         over_temperature=OverTemperature(TEMPS, TRACKING))
    tolerances = {f.name: f.tolerance for f in factors(DESIGN, spec)}
    assert tolerances["R1.R25"] == 0.001 and tolerances["R2.R25"] == 0.01
    fixed = {f.name: f for f in factors(DESIGN, _spec())}
    # a TC spreads by as much as the technology's coefficient (3 sigma), about it
    assert (fixed["C1.tc"].nominal, fixed["C1.tc"].low, fixed["C1.tc"].high) == (-200e-6, -400e-6, 0.0)
    assert (fixed["R1.tc"].low, fixed["R1.tc"].high) == (0.0, 50e-6)
    values = draw(factors(DESIGN, _spec()), 20_000, 1)
    assert np.std(values["C1.tc"]) == pytest.approx(200e-6 / 3, rel=0.05)


@pytest.mark.parametrize("rho", [0.0, 0.5, 1.0])
def test_lot_correlation_is_the_shared_fraction_of_the_tc_variance(rho):
    box = factors(DESIGN, _spec(rho=rho))
    values = draw(box, 20_000, 2, rho)
    r = np.corrcoef(values["R1.tc"], values["R2.tc"])[0, 1]
    assert r == pytest.approx(rho, abs=0.03)
    # resistors and capacitors are different lots: no correlation between them
    assert abs(np.corrcoef(values["R1.tc"], values["C1.tc"])[0, 1]) < 0.03
    # the part values themselves are drawn as without it
    np.testing.assert_array_equal(values["C1"], draw(box, 20_000, 2)["C1"])


def test_tracking_design_beats_fixed_parts_over_the_range():
    fixed = run_monte_carlo(DESIGN, _spec(), 2000, seed=1, workers=1, limit=0.005)
    tracking = run_monte_carlo(DESIGN, _spec(plan=TRACKING), 2000, seed=1, workers=1, limit=0.005)
    assert fixed.percentiles("peak")["p50"] > 0.015 and fixed.yield_against(0.005)[0] == 0.0
    assert tracking.percentiles("peak")["p99"] < 0.01
    # the per-temperature figures: at 20 °C both are close to the design
    assert fixed.percentiles_at(1)["p50"] < 1e-3 and fixed.yield_at(1, 0.005)[0] > 0.99


def test_streamed_runs_keep_per_temperature_figures():
    result = run_monte_carlo(DESIGN, _spec(), 5000, seed=3, workers=1, block=2000, limit=0.012)
    assert result.kept == 2000 and result.n == 5000
    exact = run_monte_carlo(DESIGN, _spec(), 5000, seed=3, workers=1, block=5000, limit=0.012)
    for k in range(3):
        assert result.yield_at(k, 0.012)[0] == pytest.approx(exact.yield_at(k, 0.012)[0], abs=0.03)
        assert result.percentiles_at(k)["max"] <= exact.metrics.per_temperature.peak[:, k].max() * 1.1
    assert result.yield_at(1, 0.012)[0] == 1.0 and result.yield_at(0, 0.012)[0] == 0.0


def test_cli_mc_over_temperature(run_cli, tmp_path):
    path = write_design(tmp_path / "d.json", DESIGN)
    status, out, err = run_cli("mc", path, "--n", "2000", "--temperatures", "-10,20,40",
                               "--spec", "0.5%", "--sensitivity-n", "0", "--spot-check", "0",
                               "--no-worst-case", "--lot-correlation", "0.5", "--json")
    assert status == 0, err
    data = json.loads(out)
    over = data["over_temperature"]
    assert over["temperatures"] == list(TEMPS) and over["lot_correlation"] == 0.5
    assert [r["temperature"] for r in over["per_temperature"]] == list(TEMPS)
    assert data["residual_creep_peak"] == over["worst"]["residual_creep_peak"]
    assert over["worst"]["yield"] <= min(r["yield"] for r in over["per_temperature"])
    assert {"n", "residual_creep_peak", "seconds"} <= set(data)
    status, out, err = run_cli("mc", path, "--n", "500", "--temperature-range", "-10:40",
                               "--sensitivity-n", "0", "--spot-check", "0", "--no-worst-case", "--json")
    assert status == 0 and len(json.loads(out)["over_temperature"]["temperatures"]) == 11


@pytest.mark.parametrize("args,needle", [
    (["--temperature", "20", "--temperatures", "-10,40"], "give one of them"),
    (["--temperatures", "-10,40", "--lot-correlation", "1.5"], "--lot-correlation"),
    (["--lot-correlation", "0.5"], "--lot-correlation"),
    (["--temperature-range", "40:-10"], "--temperature-range"),
    (["--temperature", "-300"], "absolute zero"),
])
def test_cli_mc_temperature_bad_input(run_cli, tmp_path, args, needle):
    path = write_design(tmp_path / "d.json", DESIGN)
    status, out, err = run_cli("mc", path, "--n", "100", *args)
    assert status == 2 and needle in err and len(err.strip().splitlines()) == 1
