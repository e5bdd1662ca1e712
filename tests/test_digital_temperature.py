"""Digital correction over temperature: each step with its own tau_k(T), exact."""

import json

import numpy as np
import pytest

from creepcomp.data import default_sensor
from creepcomp.digital.correctors import Corrector, compensate
from creepcomp.digital.record_file import correct_record_file
from creepcomp.errors import InputError
from creepcomp.io.jsonfiles import write_model
from creepcomp.io.records import Record, read_record, write_record
from creepcomp.lti import varying_lag_states
from creepcomp.model import CreepModel
from creepcomp.temperature import TemperatureLaw

LAW = TemperatureLaw.arrhenius(43000.0, 20.0)
FULL_LOAD = 100.0


def ramp_sensor(beta_per_kelvin=()) -> CreepModel:
    """The default sensor with an Arrhenius law of 43 kJ/mol about 20 °C."""
    base = default_sensor()
    law = TemperatureLaw.arrhenius(43000.0, 20.0, beta_per_kelvin)
    return CreepModel(base.beta, base.tau, base.gain, base.offset, temperature=law)


def ramp_record(seed: int = 0, noise: bool = False, irregular: bool = False, n: int = 36_000):
    """Time, load and temperature of a 10 -> 40 °C ramp under a random staircase of loads
    (with ``noise``: load and temperature jitter at every sample)."""
    rng = np.random.default_rng(seed)
    t = (np.cumsum(rng.uniform(0.05, 0.15, n)) if irregular else np.arange(n) * 0.1)
    temperature = 10.0 + 30.0 * (t - t[0]) / (t[-1] - t[0])
    levels = rng.uniform(0.0, FULL_LOAD, n // 500 + 1)
    load = np.repeat(levels, 500)[:n]
    load[:200] = 0.0
    if noise:
        load = np.clip(load + rng.normal(0.0, 0.5, n), 0.0, FULL_LOAD)
        temperature = temperature + rng.normal(0.0, 0.2, n)
    return t, load, temperature


def exact_states(model, t, load, temperature, hold, initial="relaxed"):
    """Independent simulation of the sensor (the lag states of each term, then the signal)."""
    taus = np.array(model.tau) * model.temperature.shift(0.5 * (temperature[1:] + temperature[:-1]))[:, None]
    betas = np.array(model.beta) * model.temperature.beta_factor(temperature, model.n_terms)
    c = varying_lag_states(t, load, taus, hold=hold, initial=initial)
    return model.offset + model.gain * (load + np.sum(betas * c, axis=1))


@pytest.mark.parametrize("hold", ["zero", "linear"])
@pytest.mark.parametrize("noise", [False, True])
def test_ramp_10_to_40_C_is_corrected_exactly(hold, noise):
    model = ramp_sensor()
    t, load, temperature = ramp_record(seed=3, noise=noise)
    signal = model.response(t, load, hold=hold, temperature=temperature)
    np.testing.assert_allclose(signal, exact_states(model, t, load, temperature, hold), rtol=0, atol=1e-15)
    fs = model.gain * FULL_LOAD
    corrected = compensate(t, signal, model, "subtractive", hold=hold, temperature=temperature)
    assert np.max(np.abs(corrected - (model.offset + model.gain * load))) <= 1e-9 * fs
    # the model at its reference temperature leaves creep of the order of beta0 over the ramp
    at_reference = compensate(t, signal, CreepModel(model.beta, model.tau, model.gain, model.offset),
                              "subtractive", hold=hold)
    assert np.max(np.abs(at_reference - (model.offset + model.gain * load))) > 1e-3 * fs


@pytest.mark.parametrize("method,initial", [("subtractive", "relaxed"), ("supplemental", "settled"),
                                            ("supplemental", "relaxed")])
def test_both_methods_irregular_sampling_and_amplitude_law(method, initial):
    model = ramp_sensor(beta_per_kelvin=(0.004,))
    t, load, temperature = ramp_record(seed=5, irregular=True, n=8000)
    load[:200] = 40.0 if initial == "settled" else 0.0
    signal = model.response(t, load, hold="zero", initial=initial, temperature=temperature)
    corrected = compensate(t, signal, model, method, initial=initial, temperature=temperature)
    scale = 1.0 + model.beta0 if method == "supplemental" else 1.0
    expected = model.offset + scale * model.gain * load
    assert np.max(np.abs(corrected - expected)) <= 1e-9 * model.gain * FULL_LOAD


def test_streaming_in_pieces_equals_the_batch():
    model = ramp_sensor()
    t, load, temperature = ramp_record(seed=7, n=5000)
    signal = model.response(t, load, hold="zero", temperature=temperature)
    whole = compensate(t, signal, model, temperature=temperature)
    corrector = Corrector(model, dt=0.1)
    pieces = [corrector.process(signal[i:i + 333], temperature=temperature[i:i + 333])
              for i in range(0, len(t), 333)]
    np.testing.assert_allclose(np.concatenate(pieces), whole, rtol=0, atol=1e-13 * model.gain * FULL_LOAD)


def test_a_time_invariant_model_gives_the_same_numbers_as_before():
    model = CreepModel((0.02, 0.01), (5.0, 80.0), 2e-4, 0.01)
    t = np.arange(0.0, 200.0, 0.1)
    load = np.where(t > 5, 50.0, 0.0)
    signal = model.response(t, load, hold="zero")
    # a law with zero activation energy follows the per-step path to the same result
    flat = CreepModel(model.beta, model.tau, model.gain, model.offset,
                      temperature=TemperatureLaw.arrhenius(0.0, 20.0))
    np.testing.assert_allclose(compensate(t, signal, flat, temperature=37.0), compensate(t, signal, model),
                               rtol=0, atol=1e-15)


def test_temperature_and_law_must_come_together():
    t = np.arange(0.0, 10.0, 0.1)
    with pytest.raises(InputError, match="'temperature' column.*--temperature T"):
        compensate(t, t, ramp_sensor())
    with pytest.raises(InputError, match="no temperature law"):
        compensate(t, t, default_sensor(), temperature=20.0)
    with pytest.raises(InputError, match="99 temperatures for 100 samples|temperature has 99"):
        compensate(t, t, ramp_sensor(), temperature=np.full(99, 20.0))


@pytest.fixture
def ramp_files(tmp_path):
    model = ramp_sensor()
    t, load, temperature = ramp_record(seed=11, n=6000)
    signal = model.response(t, load, hold="zero", temperature=temperature)
    record = write_record(tmp_path / "ramp.csv", Record(t, load, signal, temperature=temperature))
    plain = write_record(tmp_path / "plain.csv", Record(t, load, signal))
    return tmp_path, model, write_model(tmp_path / "model.json", model), record, plain, load


def test_record_file_in_pieces_reads_the_temperature_column(ramp_files):
    tmp, model, _, record, plain, load = ramp_files
    done = correct_record_file(record, model, output=tmp / "out.csv", block_bytes=4096)
    assert done.temperature == "column"
    corrected = read_record(tmp / "out.csv")
    assert done.after.peak_fraction <= 1e-9
    with pytest.raises(InputError, match="--temperature"):
        correct_record_file(plain, model)
    with pytest.raises(InputError, match="give one of them"):
        correct_record_file(record, model, temperature=25.0)
    assert corrected.temperature is not None


def test_cli_correct_with_the_column_and_with_a_constant(run_cli, ramp_files):
    tmp, model, model_file, record, plain, load = ramp_files
    status, out, err = run_cli("correct", record, "--model", model_file, "--json")
    assert status == 0, err
    data = json.loads(out)
    assert data["temperature"]["source"] == "column"
    assert data["creep_error"]["after"]["peak_fraction"] <= 1e-9
    status, out, err = run_cli("correct", plain, "--model", model_file, "--temperature", "25C", "--json")
    assert status == 0, err
    assert json.loads(out)["temperature"] == {"source": "constant", "constant_C": 25.0}
    status, out, err = run_cli("correct", plain, "--model", model_file)
    assert status == 2 and "'temperature' column" in err and "--temperature T" in err
    plain_model = write_model(tmp / "plain_model.json", default_sensor())
    status, out, err = run_cli("correct", plain, "--model", plain_model, "--temperature", "25")
    assert status == 2 and "no temperature law" in err
    status, out, err = run_cli("correct", record, "--model", plain_model, "--json")
    assert status == 0 and json.loads(out)["temperature"]["source"] == "unused"
    status, out, err = run_cli("correct", record, "--model", plain_model)
    assert status == 0 and "'temperature' column is not used" in out
    status, out, err = run_cli("correct", plain, "--model", model_file, "--temperature", "hot")
    assert status == 2 and "°C" in err
