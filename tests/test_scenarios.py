import numpy as np
import pytest
from rich.console import Console

from creepcomp.data import default_sensor
from creepcomp.analog.quality import sweep_hysteresis as predicted_hysteresis
from creepcomp.cli.demo import step_digital_correction
from creepcomp.digital.scenarios import (long_run, outcomes, paper_model, step_record,
    sweep_hysteresis, sweep_record)


def test_step_record_is_the_exact_response_to_held_loads():
    record = step_record(paper_model(), hold_time=100.0, rate=2.0)
    held = record.model.response(record.time, record.load, hold="zero")
    np.testing.assert_allclose(record.signal, held, rtol=0, atol=1e-13)
    assert record.load[0] == 0 and record.load.max() == 3.0


def test_raw_sweep_hysteresis_matches_the_transfer_function_prediction():
    model = default_sensor()
    record = sweep_record(model, cycles=6, quarter_points=500)
    raw = sweep_hysteresis(record, record.signal)
    expect = predicted_hysteresis(model, None)[0]
    assert raw == pytest.approx(expect, rel=1e-6)
    assert 0.015 < raw < 0.03


def test_scenario_outcomes_exact_methods_and_the_paper_as_printed():
    record = step_record(paper_model(), hold_time=100.0, rate=2.0)
    results = {o.label: o for o in outcomes(record)}
    assert results["raw signal"].error.peak_fraction > 0.02
    for label in ("subtractive, --hold zero", "supplemental, --hold zero", "paper eq. 9"):
        assert results[label].error.peak_fraction < 1e-12
    lagging = results["paper eq. 13 (as printed)"].error
    # a one-sample lag at each step of 1 (FS 3): beta0 / ((1 + beta0) * 3)
    assert lagging.peak_fraction == pytest.approx(0.03 / (1.03 * 3), rel=2e-2)

    sweep = sweep_record(paper_model(), cycles=3, quarter_points=100)
    results = {o.label: o for o in outcomes(sweep, literal=False)}
    assert results["raw signal"].hysteresis > 0.01
    assert results["subtractive, --hold linear"].hysteresis < 1e-12
    assert results["supplemental, --hold linear"].hysteresis < 1e-12
    held = results["subtractive, --hold zero"].hysteresis
    assert 1e-5 < held < 1e-3          # treating a ramp as steps costs about beta dt / tau


def test_long_run_small():
    run = long_run(samples=20_000, span=2e4, literal_samples=500)
    assert run.elapsed_over_tau == pytest.approx(2e4)
    assert run.error_subtractive < 1e-12 and run.error_supplemental < 1e-12
    assert 700 < run.literal_first_nonfinite < 720
    assert "overflow" in run.literal_warning


def test_demo_step_writes_the_figures(tmp_path, monkeypatch):
    import creepcomp.digital.scenarios as scenarios

    monkeypatch.setattr(scenarios, "step_record", lambda model: step_record(model, hold_time=60.0, rate=1.0))
    monkeypatch.setattr(scenarios, "sweep_record", lambda model: sweep_record(model, cycles=2, quarter_points=50))
    monkeypatch.setattr(scenarios, "long_run", lambda model: long_run(model, samples=5000, literal_samples=300))
    console = Console(record=True, width=200)
    step_digital_correction(tmp_path, console)
    text = console.export_text()
    for name in ("digital-steps.png", "digital-sweep.png", "digital-steps.csv", "paper-model.json"):
        assert (tmp_path / name).stat().st_size > 100
    assert "paper eq. 13" in text and "sweep hysteresis" in text and "long run" in text
