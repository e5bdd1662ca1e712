"""The model a diagnosis recommends, and a linear load cell against a noisy reference."""

import numpy as np
import pytest

from creepcomp.diagnose.recommend import model_load, recommend, usable
from creepcomp.diagnose.sensor import diagnose
from creepcomp.io.records import Record
from creepcomp.model import CreepModel
from creepcomp.transfer import StaticMap, Transfer


def _pad():
    truth = CreepModel((0.25,), (4.0,), gain=2e-4, offset=1e-4,
                       transfer=Transfer(signal_map=StaticMap("reciprocal", {"origin": 0.0})))
    t = np.arange(0.0, 240.0, 0.1)
    load = np.where((t % 40.0) >= 20.0, 1.0 + (t // 40.0) % 3, 0.0)
    signal = truth.response(t, load, hold="zero") + np.random.default_rng(1).normal(0, 2.0, t.size)
    return Record(t, load, signal)


@pytest.mark.slow
def test_a_resistive_pad_is_recommended_its_signal_path_which_correct_takes():
    record = _pad()
    rec = recommend(record, diagnose(record))
    assert rec.which == "signal path" and rec.chosen.startswith("reciprocal")
    assert usable(rec.model) is None
    model = CreepModel.from_dict(rec.model)
    held = record.time >= rec.split_time
    err = model_load(model, record.time, record.signal)[held] - record.load[held]
    assert np.sqrt(np.mean(err ** 2)) < 0.01 * np.ptp(record.load)
    static = min(c.heldout_load_rms for c in rec.candidates if c.name.startswith("static"))
    assert rec.candidates[[c.name for c in rec.candidates].index(rec.chosen)].heldout_load_rms < static


def test_a_model_the_correction_cannot_invert_is_not_usable():
    assert usable({"beta": [-1.5], "tau": [3.0]}) is not None
    assert "unstable" in usable({"beta": [2.0, -2.5], "tau": [100.0, 1.0]})
    assert usable({"beta": [0.03], "tau": [45.0]}) is None


@pytest.mark.slow
@pytest.mark.parametrize("reference_noise", [0.001, 0.005])
def test_a_linear_load_cell_against_a_noisy_reference_is_linear_creep(reference_noise):
    rng = np.random.default_rng(3)
    truth = CreepModel((0.013,), (30.0,), gain=2e-3, offset=1e-4)
    t = np.arange(0.0, 1800.0, 0.1)
    levels = rng.choice([0, 2, 5, 10, 20], size=30).astype(float)
    load = levels[np.minimum((t // 60).astype(int), 29)]
    signal = truth.response(t, load, hold="zero") + rng.normal(0, 1e-6, t.size)
    measured = load + rng.normal(0, reference_noise * 20, t.size)
    result = diagnose(Record(t, measured, signal))
    assert result.cause == "none", [f.effect for f in result.findings]
    assert "reference load's own noise" in result.to_dict()["noise_floor_method"]
    assert result.to_dict()["baseline"]["misfit_ratio"] < 1.5


def test_a_model_the_firmware_cannot_write_is_not_usable_for_it():
    flow = {"beta": [0.03], "tau": [45.0], "extensions": {"viscous_flow": {"rate": 1e-4}}}
    assert usable(flow) is None
    assert "no C corrector" in usable(flow, firmware=True)
    mapped = {"beta": [0.03], "tau": [45.0], "transfer": {"signal_map": {"form": "log", "origin": 0}},
              "extensions": {"viscous_flow": {"rate": 1e-4}}}
    assert usable(mapped, firmware=True) is not None
    assert usable({"beta": [0.03], "tau": [45.0], "transfer": {"signal_map": {"form": "log", "origin": 0}}},
                  firmware=True) is None
