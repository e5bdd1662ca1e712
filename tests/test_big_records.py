"""Long records read in pieces: the chunked reader equals the whole one, the reduction made
while reading equals the reduction of the whole record, and ``correct`` in pieces writes
the output of the whole-record correction."""

import json
import math

import numpy as np
import pytest

from creepcomp.errors import InputError
from creepcomp.io.records import (NotStreamable, Record, RecordScan, read_record,
                                  read_record_chunks, scan_record, write_record)
from creepcomp.model import CreepModel

#: CSV text per piece in these tests: some hundred rows, so that every record is many pieces.
SMALL = 4096
MODEL = CreepModel((0.01, 0.02), (8.0, 60.0), gain=0.5, offset=0.02)


def _staircase(n, dt=0.05, seed=0):
    t = np.arange(n) * dt
    levels = np.array([0.0, 2.0, 3.0, 1.0, 2.5, 0.0])
    load = levels[np.minimum((t / t[-1] * len(levels)).astype(int), len(levels) - 1)]
    signal = MODEL.response(t, load, hold="zero") + 1e-4 * np.random.default_rng(seed).standard_normal(n)
    return t, load, signal


def test_pieces_hold_exactly_what_the_whole_reader_reads(tmp_path):
    # an instrument export: preamble, mapped names, a units row with time in minutes, a constant column
    lines = ["Instrument X", "Step time,Force,Out,Temp", "min,N,mV,degC"]
    t = np.arange(3000) * 0.01
    lines += [f"{a!r},{2.0 + math.sin(a)!r},{math.cos(a)!r},{20 + a / 100!r}" for a in t.tolist()]
    path = tmp_path / "export.csv"
    path.write_text("\n".join(lines) + "\n")
    mapping = {"time": "Step time", "signal": "Out", "load": "Force", "temperature": "Temp"}
    whole = read_record(path, columns=mapping)
    pieces = list(read_record_chunks(path, columns=mapping, block_bytes=SMALL))
    assert len(pieces) > 10
    assert all(p.metadata == whole.metadata for p in pieces)
    assert whole.metadata["units.time"].startswith("s (converted from min")
    for name in ("time", "load", "signal", "temperature"):
        np.testing.assert_array_equal(np.concatenate([getattr(p, name) for p in pieces]),
                                      getattr(whole, name))
    scan = scan_record(path, columns=mapping, max_changes=10, block_bytes=SMALL)
    same = RecordScan.of(whole, max_changes=10)
    for field in ("samples", "first_time", "last_time", "step_min", "step_max", "first_load",
                  "largest_load", "load_change_count", "names"):
        assert getattr(scan, field) == getattr(same, field), field
    assert scan.load_changes is None                 # the load changes at every sample here


def test_a_bad_cell_late_in_the_file_goes_to_the_full_reader(tmp_path):
    t, load, signal = _staircase(2000)
    path = write_record(tmp_path / "rec.csv", Record(t, load, signal))
    lines = path.read_text().splitlines()
    lines[1800] = lines[1800].replace(",", ",x", 1)
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(NotStreamable):
        for _ in read_record_chunks(path, block_bytes=SMALL):
            pass
    from creepcomp.fit.reduce import read_reduced

    with pytest.raises(InputError, match="line 1801, column 'load'"):
        read_reduced(path, (500,), block_bytes=SMALL)


@pytest.mark.parametrize("ramp", [False, True])
def test_reduction_while_reading_equals_the_reduction_of_the_whole_record(tmp_path, ramp):
    from creepcomp.fit.reduce import read_reduced, reduce_record

    t, load, signal = _staircase(20_000)
    if ramp:
        load = t / t[-1]                     # the load changes at every sample: blocks over all
    record = Record(t, load, signal, temperature=20 + 0.01 * t, metadata={"units.signal": "V"})
    path = write_record(tmp_path / "rec.csv", record)
    whole = read_record(path)
    got = read_reduced(path, (5_000, 1_000), block_bytes=SMALL)
    for (red, note), m in zip(got, (5_000, 1_000)):
        want, want_note = reduce_record(whole, m)
        assert note == want_note and red.metadata == want.metadata
        assert ("over the whole record" in note) == ramp
        for name in ("time", "load", "signal", "temperature"):
            np.testing.assert_allclose(getattr(red, name), getattr(want, name), rtol=1e-13, atol=1e-13)
    # records no longer than the largest target are read whole and kept as they are
    [(same, none)] = read_reduced(path, (50_000,), block_bytes=SMALL)
    assert none is None and np.array_equal(same.signal, whole.signal)


@pytest.mark.parametrize("irregular", [False, True])
def test_correct_in_pieces_equals_the_whole_record_correction(tmp_path, irregular):
    from creepcomp.digital.correctors import compensate, creep_error
    from creepcomp.digital.record_file import correct_record_file

    t, load, signal = _staircase(6000)
    if irregular:
        t = t + 0.01 * np.sin(np.arange(len(t)))        # steps 0.03 .. 0.07 s
    path = write_record(tmp_path / "rec.csv", Record(t, load, signal, temperature=np.full(len(t), 23.0)))
    out = tmp_path / "out.csv"
    done = correct_record_file(path, MODEL, "subtractive", hold="linear", output=out,
                               output_metadata={"compensated.method": "subtractive"},
                               block_bytes=SMALL)
    assert (done.dt is None) == irregular
    whole = read_record(path)
    compensated = compensate(whole.time, whole.signal, MODEL, hold="linear")
    written = read_record(out)
    assert written.metadata == {"compensated.method": "subtractive"}
    np.testing.assert_array_equal(written.temperature, whole.temperature)
    text_columns = out.read_text().splitlines()[1].split(",")
    assert text_columns == ["time", "load", "signal", "temperature", "compensated"]
    got = np.loadtxt(out, delimiter=",", skiprows=2)[:, 4]
    np.testing.assert_allclose(got, compensated, rtol=0, atol=1e-12)
    for mine, values in ((done.before, whole.signal), (done.after, compensated)):
        ref = creep_error(whole.time, values, whole.load, MODEL)
        assert mine.rms == pytest.approx(ref.rms, rel=1e-9)
        assert mine.peak == pytest.approx(ref.peak, rel=1e-9, abs=1e-14)
        assert mine.full_scale == ref.full_scale


def test_cli_correct_streams_a_csv_and_leaves_nothing_on_a_bad_cell(run_cli, tmp_path):
    from creepcomp.io.jsonfiles import write_model

    t, load, signal = _staircase(3000)
    path = write_record(tmp_path / "rec.csv", Record(t, load, signal))
    model = write_model(tmp_path / "model.json", MODEL)
    status, stdout, err = run_cli("correct", path, "--model", model, "-o", tmp_path / "out.csv", "--json")
    assert status == 0, err
    report = json.loads(stdout)
    assert report["samples"] == 3000 and report["uniform"] and report["reduction"] > 10
    assert len(read_record(tmp_path / "out.csv")) == 3000
    lines = path.read_text().splitlines()
    lines[2900] = lines[2900] + ",extra"          # a long row near the end
    lines[2950] = lines[2950].replace(",", ",?", 1)
    path.write_text("\n".join(lines) + "\n")
    status, _, err = run_cli("correct", path, "--model", model, "-o", tmp_path / "out2.csv")
    assert status == 2 and "line 2951" in err and len(err.strip().splitlines()) == 1
    assert sorted(p.name for p in tmp_path.iterdir()) == ["model.json", "out.csv", "rec.csv"]


def test_diagnose_reduces_once_from_the_whole_record(run_cli, tmp_path):
    from creepcomp.diagnose.sensor import DIAGNOSE_MAX_SAMPLES

    t, load, signal = _staircase(3 * DIAGNOSE_MAX_SAMPLES, dt=0.2)
    path = write_record(tmp_path / "rec.csv", Record(t, load, signal))
    status, stdout, err = run_cli("diagnose", path, "--json", "--effects", "viscous_flow")
    assert status == 0, err
    out = json.loads(stdout)
    assert out["record_reduction"].startswith(f"record reduced from {len(t)} to ")
    assert out["record"]["reduced"] == out["record_reduction"]
    assert out["record"]["n_samples"] <= DIAGNOSE_MAX_SAMPLES + 10
