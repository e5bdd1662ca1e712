"""Static maps around linear creep: the maps, the load estimate, the signal-path fit and the
model a diagnosis recommends."""

import json

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from creepcomp.digital.correctors import compensate, estimate_load
from creepcomp.errors import InputError
from creepcomp.fit.signal_path import (fit_signal_path, monotone_calibration, settled_points,
                                       static_line)
from creepcomp.io.jsonfiles import read_model, write_model
from creepcomp.io.records import Record, write_record
from creepcomp.model import CreepModel
from creepcomp.transfer import StaticMap, Transfer

RECIPROCAL = Transfer(signal_map=StaticMap("reciprocal", {"origin": 0.0}))


def _presses(t):
    """Holds of 20 s at three load levels, unloaded in between."""
    return np.where((t % 40.0) >= 20.0, 1.0 + (t // 40.0) % 3, 0.0)


MAPS = [StaticMap("power", {"exponent": 0.5, "origin": -1.0}),
        StaticMap("power", {"exponent": -1.5, "origin": 0.5}),
        StaticMap("reciprocal", {"origin": 0.2}),
        StaticMap("log", {"origin": 0.0}),
        StaticMap("saturating", {"limit": 40.0}),
        StaticMap("spline", {"x": [1.0, 2.0, 4.0, 9.0], "y": [5.0, 3.0, 2.5, 0.0]})]


@pytest.mark.parametrize("m", MAPS, ids=lambda m: m.form)
@settings(max_examples=30, deadline=None)
@given(u=st.floats(1.0, 30.0))
def test_every_map_inverts_itself(m, u):
    y = m.forward(u)
    assert np.isfinite(y)
    assert m.inverse(y) == pytest.approx(u, rel=1e-9)


@pytest.mark.parametrize("m", MAPS, ids=lambda m: m.form)
def test_every_map_is_monotone_and_survives_its_model_file(m):
    x = np.linspace(1.0, 30.0, 500)
    dy = np.diff(m.forward(x))
    assert np.all(dy > 0) if m.increasing else np.all(dy < 0)
    assert StaticMap.from_dict(json.loads(json.dumps(m.to_dict()))) == m


@pytest.mark.parametrize("bad, words", [
    ({"form": "cubic"}, "use one of"),
    ({"form": "power", "exponent": 0, "origin": 0}, "exponent 0"),
    ({"form": "power", "exponent": True, "origin": 0}, "not a number"),
    ({"form": "log"}, "missing origin"),
    ({"form": "spline", "x": [0, 1, 2], "y": [0, 2, 1]}, "strictly monotone"),
    ({"form": "spline", "x": [0, 0, 2], "y": [0, 1, 2]}, "strictly increasing"),
    ({"form": "saturating", "limit": float("inf")}, "finite"),
])
def test_a_wrong_map_is_refused_by_name(bad, words):
    with pytest.raises(InputError, match=words):
        CreepModel.from_dict({"beta": [0.1], "tau": [5.0], "transfer": {"signal_map": bad}})


def test_a_model_with_maps_simulates_and_estimates_the_load_exactly():
    model = CreepModel((0.3, -0.1), (2.0, 30.0), gain=2e-4, offset=1e-4, transfer=Transfer(
        load_map=StaticMap("power", {"exponent": 0.6, "origin": 0.0}), signal_map=RECIPROCAL.signal_map))
    t = np.arange(0.0, 200.0, 0.05)
    load = _presses(t)
    resistance = model.response(t, load, hold="zero")
    assert np.all(resistance > 0) and resistance.max() / resistance.min() > 3
    np.testing.assert_allclose(estimate_load(t, resistance, model), load, atol=1e-9)
    # the compensated signal is the creep-free resistance: the static maps with no creep
    static = CreepModel((), (), model.gain, model.offset, transfer=model.transfer)
    np.testing.assert_allclose(compensate(t, resistance, model), static.response(t, load), rtol=1e-9)


def test_a_static_calibration_is_a_model_with_no_terms_that_round_trips(tmp_path):
    model = static_line([0.0, 1.0, 2.0, 3.0], [0.5, 2.5, 4.5, 6.5])
    assert model.is_static and model.gain == pytest.approx(2.0) and model.offset == pytest.approx(0.5)
    back = read_model(write_model(tmp_path / "m.json", model))
    assert back == model
    with pytest.raises(InputError, match="static calibration"):
        back.require_creep("sizing")


def test_the_monotone_calibration_is_monotone_even_through_noise():
    rng = np.random.default_rng(3)
    s = np.sort(rng.uniform(0, 10, 400))
    h = monotone_calibration(s, np.sqrt(s) + rng.normal(0, 0.3, s.size))
    assert np.all(np.diff(h.forward(np.linspace(-1, 11, 300))) > 0)


def test_settled_points_are_the_ends_of_holds():
    t = np.arange(0.0, 240.0, 0.1)
    load = _presses(t)
    rec = Record(t, load, 2 * load + 1)
    loads, signals = settled_points(rec)
    assert sorted(set(np.round(loads, 9))) == [0.0, 1.0, 2.0, 3.0]
    np.testing.assert_allclose(signals, 2 * loads + 1)
    assert settled_points(Record(t, np.sin(t / 7), np.sin(t / 7))) is None


def _pad(seed=1, noise=2.0):
    truth = CreepModel((0.25,), (4.0,), gain=2e-4, offset=1e-4, transfer=RECIPROCAL)
    t = np.arange(0.0, 240.0, 0.1)
    load = _presses(t)
    signal = truth.response(t, load, hold="zero") + np.random.default_rng(seed).normal(0, noise, t.size)
    return truth, Record(t, load, signal, metadata={"units.load": "N", "units.signal": "ohm"})


def test_a_resistive_pad_gets_its_reciprocal_map_and_creep_back():
    truth, record = _pad()
    result = fit_signal_path(record)
    assert result.chosen == "reciprocal about 0 (signal map), 1 creep term"
    assert result.model.beta[0] == pytest.approx(0.25, rel=0.05)
    assert result.model.tau[0] == pytest.approx(4.0, rel=0.05)
    chosen = result.candidate(result.chosen).heldout_load_rms
    assert chosen < result.best_static.heldout_load_rms / 5
    assert chosen < result.candidate("linear creep, 1 creep term").heldout_load_rms / 5


def test_a_sensor_without_creep_gets_a_static_calibration():
    t = np.arange(0.0, 240.0, 0.1)
    load = _presses(t)
    signal = 5.0 / (1.0 + load) + np.random.default_rng(2).normal(0, 0.01, t.size)
    result = fit_signal_path(Record(t, load, signal))
    assert result.model.is_static, result.chosen


def test_too_short_or_constant_records_are_refused():
    t = np.arange(0.0, 10.0)
    with pytest.raises(InputError, match="load never changes"):
        fit_signal_path(Record(t, np.ones(10), t))
    with pytest.raises(InputError, match="too few"):
        fit_signal_path(Record(t, t, t))


def test_correct_writes_the_load_of_a_model_with_maps(run_cli, tmp_path):
    truth, record = _pad(noise=0.0)
    rec = write_record(tmp_path / "pad.csv", record)
    model = write_model(tmp_path / "m.json", truth)
    out = tmp_path / "out.csv"
    status, stdout, err = run_cli("correct", rec, "--model", model, "-o", out, "--json")
    assert status == 0, err
    assert json.loads(stdout)["load_estimate"]["rms"] < 1e-9
    status, out, err = run_cli("firmware", model, "-o", tmp_path / "fw", "--verify", rec, "--json")
    assert status == 0, err
    load = json.loads(out)["load"]
    assert load["compared"] == 2400 and load["max_error"] <= load["bound"]


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_a_linear_sensor_with_creep_keeps_linear_creep(seed):
    truth = CreepModel((0.05,), (8.0,), gain=0.5, offset=0.1)
    t = np.arange(0.0, 300.0, 0.1)
    load = _presses(t)
    noise = np.random.default_rng(seed).normal(0, 1e-4, t.size)
    result = fit_signal_path(Record(t, load, truth.response(t, load, hold="zero") + noise))
    assert result.chosen.startswith("linear creep"), result.chosen
    assert result.model.transfer is None and result.model.beta[0] == pytest.approx(0.05, rel=0.05)


def _random_holds(seed):
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, 400.0, 0.1)
    levels = rng.uniform(0.5, 10, 40)
    return rng, t, np.where((t % 20) >= 10, levels[(t // 20).astype(int) % 40], 0.0)


@pytest.mark.parametrize("truth, expected", [
    (CreepModel((-0.3,), (6.0,), gain=1.0, offset=2.0,
                transfer=Transfer(signal_map=StaticMap("log", {"origin": 0.0}))), "log about 0 (signal map)"),
    (CreepModel((0.4,), (10.0,), gain=1.0, offset=0.5,
                transfer=Transfer(load_map=StaticMap("power", {"exponent": 0.5, "origin": 0.0}))),
     "power 0.5 about 0 (load map)"),
], ids=["relaxing, exponential response", "creep of a power of the load"])
def test_relaxation_and_creep_in_either_domain_are_found(truth, expected):
    rng, t, load = _random_holds(5)
    signal = truth.response(t, load, hold="zero") * (1 + rng.normal(0, 1e-3, t.size))
    result = fit_signal_path(Record(t, load, signal))
    assert result.chosen.startswith(expected), result.chosen
    assert result.model.beta[0] == pytest.approx(truth.beta[0], rel=0.05)
    assert result.candidate(result.chosen).heldout_load_rms < 0.2 * result.best_static.heldout_load_rms


def test_refined_exponents_approach_the_truth():
    from creepcomp.fit.signal_path import refine_exponents

    truth = CreepModel((0.3,), (5.0,), gain=1e-3, offset=1e-4,
                       transfer=Transfer(signal_map=StaticMap("power", {"exponent": -0.8, "origin": 0.0})))
    rng, t, load = _random_holds(6)
    signal = truth.response(t, load, hold="zero") * (1 + rng.normal(0, 1e-3, t.size))
    start = Transfer(signal_map=StaticMap("power", {"exponent": -0.5, "origin": 0.0}))
    refined = refine_exponents(Record(t, load, signal), start)
    assert refined.signal_map.parameters["exponent"] == pytest.approx(-0.8, abs=0.05)


def test_fit_transfer_auto_writes_the_signal_path_that_correct_inverts(run_cli, tmp_path):
    truth, record = _pad()
    rec = write_record(tmp_path / "pad.csv", record)
    out = tmp_path / "m.json"
    status, stdout, err = run_cli("fit", rec, "--transfer", "auto", "-o", out)
    assert status == 0, err
    assert "reciprocal about 0 (signal map), 1 creep term" in stdout and "chosen" in stdout
    model = read_model(out)
    assert model.transfer.signal_map.form == "reciprocal"
    assert json.loads(out.read_text())["signal_path"]["chosen"].startswith("reciprocal")
    status, stdout, err = run_cli("correct", rec, "--model", out, "--json")
    assert status == 0, err
    assert json.loads(stdout)["load_estimate"]["rms"] < 0.01 * 3.0
    status, _, err = run_cli("fit", rec, "--transfer", "auto", "--terms", "2")
    assert status == 2 and "--transfer auto" in err


@pytest.mark.slow
def test_fit_writes_no_model_that_correct_refuses(run_cli, tmp_path):
    from creepcomp.synth.soft import soft_record

    # a saturating pad whose linear fit needs creep below -100 % (as real pads did)
    rec = write_record(tmp_path / "pad.csv", soft_record("velostat", 1, max_samples=3000).record)
    out = tmp_path / "m.json"
    status, stdout, err = run_cli("fit", rec, "-o", out)
    assert status == 3 and not out.exists()
    assert "not written" in err and "beta0" in err and "--transfer auto" in err
    assert "model written" not in stdout
    status, _, err = run_cli("fit", rec, "--transfer", "auto", "-o", out)
    assert status == 0 and out.exists(), err
