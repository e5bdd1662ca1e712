"""Fitting a temperature law: several records at different temperatures (a master curve), one
record whose temperature changes, and the law the diagnosis writes with thermal_retardation."""

import json
from dataclasses import replace

import numpy as np
import pytest

from creepcomp.data import default_sensor
from creepcomp.errors import InputError
from creepcomp.fit.data import prepare
from creepcomp.fit.temperature import fit_temperature_law, record_temperature
from creepcomp.io.records import Record, write_record
from creepcomp.model import CreepModel
from creepcomp.programs import staircase
from creepcomp.synth.common import NoiseSpec, sample_noise
from creepcomp.temperature import GAS_CONSTANT, ZERO_CELSIUS, TemperatureLaw

EA = 43e3
ARRHENIUS = TemperatureLaw.arrhenius(EA, 20.0)
WLF = TemperatureLaw(20.0, "wlf", c1=5.0, c2=150.0)
#: White noise of 1e-4 of full scale plus a coloured (AR(1), 2 s) part of the same size.
NOISE = NoiseSpec(white=1e-4, coloured=1e-4, correlation_time=2.0)


def _time_and_load(rate: float = 2.0, duration: float = 1200.0):
    t = np.arange(0.0, duration, 1.0 / rate)
    load = staircase(levels=(1.0, 0.5, 1.0, 0.0, 0.6, 0.0), hold=180.0, start=60.0).sample(t)
    return t, load


def _records(law: TemperatureLaw, temperatures=(-10.0, 20.0, 40.0), seed: int = 4,
             beta_per_kelvin=()) -> list[Record]:
    """The default sensor with ``law`` at each temperature; gain and offset drift with it."""
    model = replace(default_sensor(), temperature=replace(law, beta_per_kelvin=tuple(beta_per_kelvin)))
    rng = np.random.default_rng(seed)
    t, load = _time_and_load()
    out = []
    for temp in temperatures:
        column = np.full(t.size, temp)
        signal = ((1.0 + 0.002 * (temp - 20.0)) * model.response(t, load, temperature=column)
                  + 0.001 * temp + sample_noise(t, NOISE, rng))
        out.append(Record(t, load, signal, column + rng.normal(0.0, 0.05, t.size), source=f"{temp:g}C"))
    return out


def _ramp(law: TemperatureLaw, seed: int = 5) -> Record:
    """One record whose temperature ramps from 10 to 40 °C under a staircase of load steps."""
    model = replace(default_sensor(), temperature=law)
    rng = np.random.default_rng(seed)
    t, load = _time_and_load()
    temp = 10.0 + 30.0 * t / t[-1]
    return Record(t, load, model.response(t, load, temperature=temp) + sample_noise(t, NOISE, rng), temp)


def _covers(value: float, sigma: float, truth: float, within: float = 0.1) -> None:
    assert abs(value - truth) <= within * abs(truth)
    assert abs(value - truth) <= 2.0 * sigma, (value, sigma, truth)


def test_three_records_give_the_activation_energy_with_an_uncertainty_that_covers_it():
    fit = fit_temperature_law([prepare(r) for r in _records(ARRHENIUS)])
    ea, sd = fit.law_estimates()["activation_energy"]
    _covers(ea, sd, EA)
    assert 0 < sd < 0.01 * EA
    assert fit.law.reference == pytest.approx(20.0, abs=0.05)       # the middle record
    assert fit.n_terms == 1
    _covers(fit.model.tau[0], fit.sigmas["tau[0]"], 45.0)
    # each record's own gain: the sensitivity's drift with temperature is not taken for creep
    gains = [r["gain"] for r in fit.records]
    assert gains == pytest.approx([0.94, 1.0, 1.04], abs=2e-4)
    # the model file reads back with its law and the law's uncertainty
    model = CreepModel.from_dict(json.loads(json.dumps(fit.to_dict())))
    assert model.temperature.activation_energy == pytest.approx(ea)
    assert model.temperature.uncertainty["activation_energy"] == pytest.approx(sd)


def test_one_record_with_a_temperature_ramp_gives_the_activation_energy():
    fit = fit_temperature_law([prepare(_ramp(ARRHENIUS))])
    ea, sd = fit.law_estimates()["activation_energy"]
    _covers(ea, sd, EA)
    assert fit.law.reference == pytest.approx(25.0, abs=0.1)        # the record's mean
    expected_tau = 45.0 * float(ARRHENIUS.shift(fit.law.reference))
    assert fit.model.tau[0] == pytest.approx(expected_tau, rel=0.01)
    assert fit.records[0]["temperature_used"] == "column"


def test_wlf_law_gives_the_shift_factors_over_the_range():
    fit = fit_temperature_law([prepare(r) for r in _records(WLF)], law="wlf", n_terms=1)
    for temp in (-10.0, 40.0):
        assert float(fit.law.shift(temp)) == pytest.approx(float(WLF.shift(temp)), rel=0.03)
    (c1, s1), (c2, s2) = fit.law_estimates().values()
    _covers(c1, s1, 5.0, within=0.2)
    _covers(c2, s2, 150.0, within=0.2)


def test_the_joint_fit_chooses_the_terms_a_ramp_needs():
    """Two terms under a temperature ramp: the record alone, fitted without its temperature,
    may support fewer terms; the joint fit adds the one it needs, and no more."""
    model = CreepModel((0.01, 0.02), (5.0, 100.0), temperature=ARRHENIUS)
    t = np.arange(0.0, 1200.0, 1.0)
    load = staircase(levels=(1.0, 0.5, 1.0, 0.0), hold=270.0, start=60.0).sample(t)
    temp = 10.0 + 30.0 * t / t[-1]
    signal = model.response(t, load, temperature=temp) + np.random.default_rng(6).normal(0, 1e-4, t.size)
    fit = fit_temperature_law([prepare(Record(t, load, signal, temp))])
    assert fit.n_terms == 2
    assert [o["n_terms"] for o in fit.orders if o["chosen"]] == [2]
    _covers(*fit.law_estimates()["activation_energy"], EA)
    shift = float(ARRHENIUS.shift(fit.law.reference))
    assert np.array(fit.model.tau) == pytest.approx(np.array([5.0, 100.0]) * shift, rel=0.05)


def test_amplitudes_per_kelvin():
    fit = fit_temperature_law([prepare(r) for r in _records(ARRHENIUS, beta_per_kelvin=(0.004,))],
                              beta_per_kelvin=True, n_terms=1)
    b, sd = fit.values["beta_per_kelvin[0]"], fit.sigmas["beta_per_kelvin[0]"]
    _covers(b, sd, 0.004, within=0.2)
    assert fit.law.uncertainty["beta_per_kelvin"] == [pytest.approx(sd)]
    _covers(*fit.law_estimates()["activation_energy"], EA)


def test_temperatures_given_per_record_and_the_tolerance_of_a_constant_column():
    records = _records(ARRHENIUS, (0.0, 30.0))
    data = prepare(records[0])
    assert np.all(record_temperature(data) == np.mean(records[0].temperature))
    assert np.all(record_temperature(data, 5.0) == 5.0)
    wobbling = prepare(replace(records[0], temperature=records[0].temperature + np.linspace(0, 2, len(records[0]))))
    assert np.ptp(record_temperature(wobbling)) > 1.9


@pytest.mark.parametrize("case,needle", [
    ("no column", "no temperature column"),
    ("one temperature", "span"),
    ("wlf two", "three temperatures"),
    ("count", "give one per record"),
    ("law", "--law 'vft'"),
])
def test_bad_temperature_inputs_are_named(case, needle):
    recs = _records(ARRHENIUS, (0.0, 30.0))
    data = [prepare(r) for r in recs]
    kwargs = {}
    if case == "no column":
        data = [prepare(replace(r, temperature=None)) for r in recs]
    elif case == "one temperature":
        kwargs["temperatures"] = (20.0, 20.0)
    elif case == "wlf two":
        kwargs["law"] = "wlf"
    elif case == "count":
        kwargs["temperatures"] = (20.0,)
    else:
        kwargs["law"] = "vft"
    with pytest.raises(InputError, match=needle):
        fit_temperature_law(data, **kwargs)


def test_cli_fits_three_records_and_writes_the_law(run_cli, tmp_path):
    paths = []
    for rec, temp in zip(_records(ARRHENIUS), (-10, 20, 40)):
        paths.append(write_record(tmp_path / f"r{temp}.csv", replace(rec, temperature=None)))
    status, out, err = run_cli("fit", *paths, "--temperature", "-10,20,40", "--terms", "1",
                               "-o", tmp_path / "m.json")
    assert status == 0, err
    assert "activation energy E_a = " in out and "kJ/mol" in out
    block = json.loads((tmp_path / "m.json").read_text())["temperature"]
    assert block["law"] == "arrhenius" and block["reference"] == 20.0
    assert abs(block["activation_energy"] - EA) <= 2 * block["uncertainty"]["activation_energy"]
    status, _, err = run_cli("fit", *paths, "--temperature", "-10,20")
    assert status == 2 and "gives 2 temperatures for 3 records" in err
    status, _, err = run_cli("fit", *paths)
    assert status == 2 and "no temperature column" in err


def test_diagnose_writes_the_temperature_law_of_thermal_retardation():
    from creepcomp.diagnose.effects import simulate_extended
    from creepcomp.diagnose.sensor import diagnose

    kappa_true = 0.06          # 1/K: E_a = 44.3 kJ/mol at 25 °C
    model = replace(default_sensor(), extensions={"thermal_retardation": {
        "kappa": kappa_true, "reference_temperature": 25.0}})
    t = np.arange(0.0, 600.0, 1.0)
    load = staircase(levels=(1.0, 0.0, 1.0), hold=180.0, start=40.0).sample(t)
    temp = 10.0 + 30.0 * t / t[-1]
    signal = simulate_extended(model, t, load, temp) + np.random.default_rng(3).normal(0, 1e-4, t.size)
    d = diagnose(Record(t, load, signal, temp))
    assert [f.effect for f in d.findings] == ["thermal_retardation"]
    block = d.extended_model["temperature"]
    kappa = d.extended_model["extensions"]["thermal_retardation"]["kappa"]
    per_kappa = GAS_CONSTANT * (block["reference"] + ZERO_CELSIUS) ** 2
    assert block["law"] == "arrhenius" and block["reference"] == pytest.approx(25.0)
    assert block["activation_energy"] == pytest.approx(kappa * per_kappa)
    sd = block["uncertainty"]["activation_energy"]
    assert sd == pytest.approx(d.findings[0].uncertainty["kappa"] * per_kappa, rel=1e-6)
    assert abs(block["activation_energy"] - kappa_true * per_kappa) <= 3 * sd
    assert "temperature" not in d.baseline_model
    assert CreepModel.from_dict(d.extended_model).temperature.activation_energy == pytest.approx(
        block["activation_energy"])
