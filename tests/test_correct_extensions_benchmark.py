"""The correction benchmark's comparison (``benchmarks/correct_extensions.py``): a delayed
record's baseline, the samples compared, errors in load units."""

import sys
from pathlib import Path

import numpy as np
import pytest

from creepcomp.diagnose.effects.time_offset import latency, shifted
from creepcomp.errors import InputError
from creepcomp.fit.data import prepare
from creepcomp.fit.solver import fit_structure
from creepcomp.fit.starts import one_term_starts
from creepcomp.fit.structure import Structure
from creepcomp.io.records import Record
from creepcomp.lti import lag_states
from creepcomp.model import CreepModel

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
import correct_extensions as bench  # noqa: E402

DELAY = 0.6


def _delayed_record() -> Record:
    """Load steps read 6 samples late by a sensor of 2 % creep at 20 s."""
    t = np.arange(0.0, 120.0, 0.1)
    load = np.select([t < 10, t < 40, t < 70, t < 95], [0.0, 1.0, 0.3, 0.8], 0.0)
    seen = shifted(t, load, DELAY)
    signal = 2.0 * (seen + 0.02 * lag_states(t, seen, [20.0])[:, 0])
    signal = signal + np.random.default_rng(0).normal(0.0, 1e-3, t.size)
    return Record(t, load, signal)


def test_latency_is_the_delay_and_half_the_window():
    assert latency({"delay": 0.5}) == 0.5
    assert latency({"delay": 0.5, "width": 0.4}) == pytest.approx(0.7)
    assert latency({"delay": -0.3, "width": 0.2}) == 0.0     # a signal read early waits for nothing


def test_a_delay_gives_a_one_term_baseline_the_model_file_refuses():
    record = _delayed_record()
    data = prepare(record)
    fit = fit_structure(data, Structure(1), one_term_starts(data), with_cov=False)
    # the one term's best likeness of the delay: an all-pass, negative instantaneous gain
    assert fit.gain < 0 and fit.betas[0] < -1
    with pytest.raises(InputError, match="beta0 must be greater than -1"):
        fit.creep_model()


def test_readable_baseline_is_a_model_file_can_hold():
    model = bench.readable_baseline(_delayed_record())
    assert model is not None and model.beta0 > -1
    CreepModel.from_dict(model.to_dict())
    # its DC gain is the sensor's
    assert model.gain * (1 + model.beta0) == pytest.approx(2.0 * 1.02, rel=0.05)


def test_the_samples_compared_end_before_the_delays_latency():
    record = _delayed_record()
    model = CreepModel((0.02,), (20.0,), 2.0, 0.0, {"time_offset": {"delay": DELAY, "width": 0.0}})
    known = bench.known_samples(record, model)
    assert record.time[known - 1] <= record.time[-1] - DELAY < record.time[known]
    assert bench.known_samples(record, CreepModel((0.02,), (20.0,), 2.0, 0.0)) == len(record)


def test_errors_compare_in_load_units_whatever_the_gain():
    load = np.repeat([0.0, 1.0, 0.4, 0.0], 50)
    values = 3.0 + 2.0 * load + np.random.default_rng(1).normal(0.0, 0.01, load.size)
    assert bench.load_unit_rms(values, load) == pytest.approx(bench.load_unit_rms(10.0 * values, load))
    assert bench.load_unit_rms(values, load) == pytest.approx(0.005, rel=0.2)


def test_a_thermal_retardation_model_with_its_own_temperature_block_is_corrected():
    from creepcomp.diagnose.effects import extension_inverses
    from creepcomp.temperature import TemperatureLaw

    law = TemperatureLaw.from_kappa(0.05, 25.0)
    own = CreepModel((0.03,), (45.0,), 0.05, 0.0,
                     {"thermal_retardation": {"kappa": 0.05, "reference_temperature": 25.0}}, law)
    assert set(extension_inverses(own)) == {"thermal_retardation"}
    # a temperature law beside another extension would be a second law: refused
    other = CreepModel((0.03,), (45.0,), 0.05, 0.0, {"time_offset": {"delay": 0.5}}, law)
    with pytest.raises(InputError, match="temperature law cannot be applied together"):
        extension_inverses(other)
