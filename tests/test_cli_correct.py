import json

import numpy as np
import pytest

from creepcomp.io.jsonfiles import write_model
from creepcomp.model import CreepModel
from creepcomp.io.records import Record, read_record, write_record

MODEL = CreepModel((0.01, 0.02), (8.0, 60.0), gain=0.5, offset=0.02)


@pytest.fixture
def files(tmp_path):
    t = np.arange(0, 600.0, 0.5)
    load = np.select([t < 30, t < 250, t < 400], [0.0, 2.0, 3.0], 1.0)
    signal = MODEL.response(t, load, hold="zero")
    record = write_record(tmp_path / "rec.csv", Record(t, load, signal, temperature=np.full(len(t), 23.0),
                                                       metadata={"units.signal": "V", "units.load": "g"}))
    model = write_model(tmp_path / "model.json", MODEL)
    return tmp_path, record, model, t, load


def test_correct_writes_the_record_plus_compensated_and_reports_the_error(run_cli, files):
    tmp, record, model, t, load = files
    out = tmp / "out.csv"
    status, stdout, err = run_cli("correct", record, "--model", model, "--method", "subtractive",
                                  "-o", out)
    assert status == 0, err
    assert "Creep error against the load reference" in stdout and "% " in stdout and "mV" in stdout
    assert f"corrected record written to {out}" in stdout
    header = [line for line in out.read_text().splitlines() if not line.startswith("#")][0]
    assert header == "time,load,signal,temperature,compensated,load_estimate"
    back = read_record(out)
    assert back.metadata["compensated.method"] == "subtractive"
    assert back.metadata["units.signal"] == "V"
    np.testing.assert_array_equal(back.signal, read_record(record).signal)
    compensated = _column(out, "compensated")
    np.testing.assert_allclose(compensated, MODEL.offset + MODEL.gain * load, rtol=0, atol=1e-13)
    np.testing.assert_allclose(_column(out, "load_estimate"), load, rtol=0, atol=1e-12)


def _column(path, name):
    lines = [line for line in path.read_text().splitlines() if not line.startswith("#")]
    index = lines[0].split(",").index(name)
    return np.array([float(line.split(",")[index]) for line in lines[1:]])


@pytest.mark.parametrize("method,factor", [("subtractive", 1.0), ("supplemental", 1.03)])
def test_json_report(run_cli, files, method, factor):
    _, record, model, t, load = files
    status, stdout, err = run_cli("correct", record, "--model", model, "--method", method, "--json")
    assert status == 0, err
    data = json.loads(stdout)
    assert data["method"] == method and data["hold"] == "zero" and data["uniform"] is True
    assert data["sample_interval"] == pytest.approx(0.5)
    assert data["saturation_factor"] == pytest.approx(factor)
    before, after = data["creep_error"]["before"], data["creep_error"]["after"]
    assert after["full_scale"] == pytest.approx(MODEL.gain * factor * 3.0)
    assert before["peak_fraction"] > 5e-3 and after["peak_fraction"] < 1e-12
    assert data["reduction"] > 1e9
    # the load comes back in load units whatever the method's scale
    assert data["load_estimate"]["rms"] < 1e-12 and data["load_estimate"]["unit"] == "g"
    assert data["starts_loaded"] is False and data["notes"] == []


def test_a_record_that_starts_loaded_gets_a_note_and_settled_start_fixes_it(run_cli, tmp_path):
    t = np.arange(0, 400.0, 1.0)
    load = np.where(t < 200, 1.0, 0.5)
    signal = MODEL.response(t, load, hold="zero", initial="settled")
    record = write_record(tmp_path / "loaded.csv", Record(t, load, signal))
    model = write_model(tmp_path / "m.json", MODEL)
    status, stdout, _ = run_cli("correct", record, "--model", model, "--json")
    data = json.loads(stdout)
    assert data["starts_loaded"] and "--initial settled" in data["notes"][0]
    assert data["creep_error"]["after"]["peak_fraction"] > 1e-3
    status, stdout, _ = run_cli("correct", record, "--model", model)
    assert "starts loaded" in stdout and "--initial settled" in stdout
    status, stdout, _ = run_cli("correct", record, "--model", model, "--initial", "settled", "--json")
    data = json.loads(stdout)
    assert data["initial"] == "settled" and data["creep_error"]["after"]["peak_fraction"] < 1e-12


def test_irregular_record_column_mapping_linear_hold_and_plot(run_cli, tmp_path):
    rng = np.random.default_rng(0)
    t = np.cumsum(rng.uniform(0.1, 3.0, 500))
    load = np.clip(np.sin(t / 50.0) * 2, -1.5, 1.5)
    signal = MODEL.response(t, load, hold="linear")
    path = tmp_path / "export.csv"
    lines = ["tR;P;Ri;other"] + [f"{float(a)!r};{float(b)!r};{float(c)!r};7" for a, b, c in zip(t, load, signal)]
    path.write_text("\n".join(lines) + "\n")
    model = write_model(tmp_path / "m.json", MODEL)
    plot = tmp_path / "c.png"
    status, stdout, err = run_cli("correct", path, "--model", model, "--columns",
                                  "time=tR,load=P,signal=Ri", "--hold", "linear", "--plot", plot, "--json")
    assert status == 0, err
    data = json.loads(stdout)
    assert data["uniform"] is False and data["sample_interval"] is None
    assert data["creep_error"]["after"]["peak_fraction"] < 1e-12
    assert plot.stat().st_size > 10_000
    status, stdout, _ = run_cli("correct", path, "--model", model, "--columns", "time=tR,load=P,signal=Ri")
    assert "irregular" in stdout and status == 0


@pytest.mark.parametrize("args,needle", [
    ([], "--model FILE"),
    (["--model", "MODEL", "--method", "additive"], "method 'additive'"),
    (["--model", "MODEL", "--initial", "warm"], "initial state 'warm'"),
    (["--model", "MODEL", "--hold", "cubic"], "hold 'cubic'"),
    (["--model", "missing.json"], "no such file"),
    (["--model", "MODEL", "--columns", "time"], "--columns"),
])
def test_bad_options_give_one_line_and_status_2(run_cli, files, args, needle):
    tmp, record, model, _, _ = files
    args = [str(model) if a == "MODEL" else (str(tmp / a) if a.endswith(".json") else a) for a in args]
    status, stdout, err = run_cli("correct", record, *args)
    assert status == 2
    assert needle in err and len(err.strip().splitlines()) == 1 and "Traceback" not in err


def test_bad_record_is_named_with_its_line(run_cli, files):
    tmp, _, model, _, _ = files
    bad = tmp / "bad.csv"
    bad.write_text("time,load,signal\n0,0,0\n1,1,nan\n")
    status, _, err = run_cli("correct", bad, "--model", model)
    assert status == 2 and "line 3" in err and "signal" in err


def test_model_extensions_are_applied_not_dropped(run_cli, files):
    tmp, record, _, t, load = files
    from creepcomp.diagnose.effects import simulate_extended

    extended = CreepModel.from_dict({**MODEL.to_dict(), "extensions": {"viscous_flow": {"rate": 1e-4}}})
    signal = simulate_extended(extended, t, load, hold="zero")
    write_record(tmp / "flow.csv", Record(t, load, signal))
    model = tmp / "extended.json"
    model.write_text(json.dumps(extended.to_dict()))
    status, stdout, err = run_cli("correct", tmp / "flow.csv", "--model", model, "--json")
    assert status == 0, err
    out = json.loads(stdout)
    assert not any("not used" in note for note in out["notes"])
    assert "integral" in out["extensions"]["viscous_flow"]
    assert out["creep_error"]["after"]["peak"] < 1e-9


def test_correct_streamed_in_chunks_gives_the_in_memory_figures(files):
    from creepcomp.digital.correctors import Corrector, compensate, creep_error

    _, _, _, t, load = files
    rng = np.random.default_rng(4)
    signal = MODEL.response(t, load, hold="zero") + 1e-4 * rng.standard_normal(len(t))
    whole = Corrector(MODEL, dt=0.5).process(signal)
    streamed = compensate(t, signal, MODEL, chunk=97)
    np.testing.assert_allclose(streamed, whole, rtol=0, atol=1e-12)
    # the error's figures: one pass over the record, or 7 samples at a time
    one = creep_error(t, streamed, load, MODEL, chunk=len(t))
    ref = MODEL.offset + MODEL.gain * load
    err = streamed - ref
    assert one.rms == float(np.sqrt(np.mean(err ** 2)))
    assert one.peak == float(np.max(np.abs(err))) and one.peak_time == t[np.argmax(np.abs(err))]
    many = creep_error(t, streamed, load, MODEL, chunk=7)
    assert (many.peak, many.peak_time, many.full_scale) == (one.peak, one.peak_time, one.full_scale)
    assert many.rms == pytest.approx(one.rms, rel=1e-12)
