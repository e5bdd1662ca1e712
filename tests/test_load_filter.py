"""The load filter: a moving average of the load estimate, chosen on held-out data."""

import json

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from creepcomp.diagnose.recommend import usable
from creepcomp.digital.correctors import compensate, estimate_load
from creepcomp.digital.record_file import correct_record_file
from creepcomp.errors import InputError
from creepcomp.fit.signal_path import Candidate, choose_load_filter, static_line
from creepcomp.io.jsonfiles import write_model
from creepcomp.io.records import Record, read_record, write_record
from creepcomp.load_filter import LoadFilter, moving_average
from creepcomp.model import CreepModel


@settings(max_examples=60, deadline=None)
@given(st.lists(st.floats(-1e3, 1e3), min_size=1, max_size=60), st.integers(1, 9), st.integers(1, 59))
def test_a_moving_average_in_pieces_is_the_whole_one_and_each_is_the_mean_of_its_window(values, n, cut):
    x = np.array(values)
    whole, _ = moving_average(x, n)
    for i in range(x.size):
        assert whole[i] == pytest.approx(x[max(0, i - n + 1):i + 1].mean(), abs=1e-9)
    cut = min(cut, x.size)
    first, kept = moving_average(x[:cut], n)
    rest, _ = moving_average(x[cut:], n, kept)
    np.testing.assert_allclose(np.concatenate([first, rest]), whole, atol=1e-9)


def test_the_filter_averages_over_the_same_time_at_another_interval_and_bad_blocks_are_named():
    f = LoadFilter(16, 0.02)
    assert (f.samples_at(0.02), f.samples_at(0.04), f.samples_at(0.01), f.samples_at(None)) == (16, 8, 32, 16)
    assert LoadFilter.from_dict(f.to_dict()) == f
    for block, needle in [({"form": "median", "samples": 3, "interval": 0.1}, "'median' is not known"),
                          ({"samples": 3}, "missing 'interval'"),
                          ({"samples": 2.5, "interval": 0.1}, "whole number"),
                          ({"samples": 0, "interval": 0.1}, "1 to 256"),
                          ({"samples": 3, "interval": -1.0}, "positive")]:
        with pytest.raises(InputError, match=needle):
            CreepModel.from_dict({"beta": [0.1], "tau": [2.0], "load_filter": block})
    model = CreepModel.from_dict({"beta": [0.1], "tau": [2.0], "load_filter": {"samples": 4, "interval": 0.1}})
    assert CreepModel.from_dict(json.loads(json.dumps(model.to_dict()))) == model
    assert CreepModel((0.1,), (2.0,), load_filter=LoadFilter(1, 0.1)).load_filter is None


def _noisy_presses(noise=0.1, seed=0):
    t = np.arange(0.0, 200.0, 0.02)
    load = 0.5 - 0.5 * np.cos(2 * np.pi * t / 20.0)
    signal = 2.0 * load + np.random.default_rng(seed).normal(0.0, noise, t.size)
    return Record(t, load, signal)


def test_a_noisy_smooth_record_gets_a_filter_and_a_clean_step_record_none():
    record = _noisy_presses()
    early = record.time < 150.0
    member = Candidate("static line", static_line(record.load[early], record.signal[early]), 0.0, 0)
    chosen, scores = choose_load_filter(record, member)
    assert chosen is not None and chosen.samples > 1 and scores[chosen.samples] < 0.5 * scores[1]
    t = np.arange(0.0, 200.0, 0.02)
    load = np.where((t % 20.0) >= 10.0, 1.0, 0.0)
    clean = Record(t, load, 2.0 * load + np.random.default_rng(0).normal(0.0, 1e-4, t.size))
    member = Candidate("static line", static_line(clean.load[early], clean.signal[early]), 0.0, 0)
    assert choose_load_filter(clean, member)[0] is None


def test_correct_filters_the_load_estimate_not_the_compensated_signal_whole_and_in_pieces(run_cli, tmp_path):
    model = CreepModel((0.2,), (5.0,), gain=2.0, offset=0.1, load_filter=LoadFilter(8, 0.05))
    plain = CreepModel((0.2,), (5.0,), gain=2.0, offset=0.1)
    t = np.arange(0.0, 300.0, 0.05)
    load = np.where((t % 60.0) >= 30.0, 3.0, 0.0)
    signal = plain.response(t, load, hold="zero") + np.random.default_rng(2).normal(0, 0.05, t.size)
    record = write_record(tmp_path / "rec.csv", Record(t, load, signal))
    model_path = write_model(tmp_path / "model.json", model)
    out = tmp_path / "whole.csv"
    status, stdout, err = run_cli("correct", record, "--model", model_path, "-o", out)
    assert status == 0, err
    assert "then a moving average of 8 load estimates (0.4 s at 0.05 s a sample)" in stdout
    outputs = {"whole": read_record(out, columns={"signal": "compensated", "load": "load_estimate"})}
    done = correct_record_file(record, model, output=tmp_path / "pieces.csv", block_bytes=4096)
    assert done is not None
    outputs["pieces"] = read_record(tmp_path / "pieces.csv",
                                    columns={"signal": "compensated", "load": "load_estimate"})
    np.testing.assert_allclose(outputs["pieces"].load, outputs["whole"].load, atol=1e-9)
    expected = estimate_load(t, signal, model)
    np.testing.assert_allclose(outputs["whole"].load, expected, atol=1e-9)
    np.testing.assert_allclose(outputs["whole"].signal, compensate(t, signal, plain), atol=1e-9)
    unfiltered = estimate_load(t, signal, plain)
    steady = (t % 30.0) > 1.0          # the average lags a step by 0.4 s
    assert np.std((expected - load)[steady]) < 0.5 * np.std((unfiltered - load)[steady])


def test_a_filter_beside_an_extension_is_refused_for_the_firmware_with_its_reason():
    block = {"beta": [0.03], "tau": [45.0], "load_filter": {"samples": 4, "interval": 0.1}}
    assert usable(block, firmware=True) is None
    why = usable({**block, "extensions": {"viscous_flow": {"rate": 1e-4}}}, firmware=True)
    assert why is not None and "firmware" in why


@pytest.mark.slow
def test_the_recommended_model_of_a_noisy_taxel_carries_its_filter_which_correct_and_firmware_take():
    from creepcomp.diagnose.recommend import model_load, recommend
    from creepcomp.diagnose.sensor import diagnose

    record = _noisy_presses(noise=0.2, seed=3)
    rec = recommend(record, diagnose(record))
    assert "load_filter" in rec.model and "moving average" in rec.reason, rec.reason
    assert usable(rec.model, firmware=True) is None
    model = CreepModel.from_dict(rec.model)
    held = record.time >= rec.split_time
    unfiltered = CreepModel.from_dict({k: v for k, v in rec.model.items() if k != "load_filter"})
    err = model_load(model, record.time, record.signal)[held] - record.load[held]
    err0 = model_load(unfiltered, record.time, record.signal)[held] - record.load[held]
    assert np.sqrt(np.mean(err ** 2)) < 0.6 * np.sqrt(np.mean(err0 ** 2))


def test_correct_names_the_samples_it_averages_at_the_records_own_interval(run_cli, tmp_path):
    plain = CreepModel((0.2,), (5.0,), gain=2.0, offset=0.1)
    t = np.arange(0.0, 60.0, 0.025)
    load = np.where(t >= 10.0, 1.0, 0.0)
    record = write_record(tmp_path / "rec.csv", Record(t, load, plain.response(t, load, hold="zero")))
    model = write_model(tmp_path / "model.json",
                        CreepModel((0.2,), (5.0,), gain=2.0, offset=0.1, load_filter=LoadFilter(4, 0.05)))
    status, stdout, err = run_cli("correct", record, "--model", model)
    assert status == 0, err
    assert "then a moving average of 8 load estimates (0.2 s at 0.025 s a sample)" in stdout
