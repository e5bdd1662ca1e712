"""Long records read in pieces: the chunked reader equals the whole one, the reduction made
while reading equals the reduction of the whole record, and ``correct`` in pieces writes
the output of the whole-record correction."""

import json
import math

import numpy as np
import pytest

from creepcomp.errors import InputError
from creepcomp.io.records import (NotStreamable, Record, RecordScan, open_record_stream,
                                  parse_record, read_record, read_record_chunks, record_writer,
                                  scan_record, write_record)
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
    stream = open_record_stream(path, block_bytes=SMALL)
    assert stream.whole_reason is None
    pieces = list(stream)
    assert 0 < sum(len(p) for p in pieces) < 1800 and "after row" in stream.whole_reason
    assert stream.scan() is None
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


def test_a_file_of_few_pieces_is_read_whole_and_a_longer_one_in_pieces(tmp_path, monkeypatch):
    from creepcomp.fit import reduce as reduction

    t, load, signal = _staircase(20_000)
    path = write_record(tmp_path / "rec.csv", Record(t, load, signal))
    want, want_note = reduction.reduce_record(read_record(path), 2_000)
    streamed = []
    monkeypatch.setattr(reduction, "open_record_stream",
                        lambda *args, **kw: streamed.append(1) or open_record_stream(*args, **kw))
    fewest = -(-path.stat().st_size // reduction.WHOLE_PIECES)    # bytes per piece: whole
    [(whole, note)] = reduction.read_reduced(path, (2_000,), block_bytes=fewest)
    assert streamed == [] and note == want_note and whole.metadata == want.metadata
    for name in ("time", "load", "signal"):
        assert np.array_equal(getattr(whole, name), getattr(want, name))
    [(piecewise, note)] = reduction.read_reduced(path, (2_000,), block_bytes=fewest - 1)
    assert streamed == [1] and note == want_note and piecewise.metadata == want.metadata
    np.testing.assert_allclose(piecewise.signal, want.signal, rtol=1e-13, atol=1e-13)


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
    assert text_columns == ["time", "load", "signal", "temperature", "compensated", "load_estimate"]
    got = np.loadtxt(out, delimiter=",", skiprows=2)
    np.testing.assert_allclose(got[:, 4], compensated, rtol=0, atol=1e-12)
    from creepcomp.digital.correctors import load_from_compensated

    np.testing.assert_allclose(got[:, 5], load_from_compensated(compensated, MODEL), rtol=0, atol=1e-9)
    assert done.load_rms == pytest.approx(np.sqrt(np.mean((got[:, 5] - whole.load) ** 2)), rel=1e-6)
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


#: Faults of a long record and the message every reader gives for each.
FAULTS = {
    "text": (lambda row: row.replace(",", ",x", 1), "column 'load': 'x0' is not a number"),
    "infinite": (lambda row: "inf" + row[row.index(","):], "column 'time': 'inf' is not a finite number"),
    "blank": (lambda row: row[:row.index(",") + 1] + row[row.rindex(","):], "column 'load': '' is not a number"),
    "short": (lambda row: row[:row.rindex(",")], "column 'signal' is missing (the row has 2 fields)"),
    "back": (lambda row: "0.5" + row[row.index(","):], "column 'time': 0.5 is earlier than the previous time"),
    "repeat": (lambda row: None, "column 'time': 89.9 repeats the previous time (89.9)"),
}


@pytest.mark.parametrize("fault", list(FAULTS))
def test_every_reader_gives_the_same_message_for_the_same_fault(tmp_path, fault):
    from creepcomp.digital.record_file import correct_record_file
    from creepcomp.fit.reduce import read_reduced

    t, load, signal = _staircase(2000)
    path = write_record(tmp_path / "rec.csv", Record(t, load, signal))
    lines = path.read_text().splitlines()
    change, needle = FAULTS[fault]
    lines[1800] = lines[1799] if change(lines[1800]) is None else change(lines[1800])
    text = "\n".join(lines) + "\n"
    path.write_text(text)
    messages = set()
    for read in (lambda: parse_record(text, str(path)), lambda: read_record(path),
                 lambda: read_reduced(path, (500,), block_bytes=SMALL)):
        with pytest.raises(InputError) as info:
            read()
        messages.add(str(info.value))
    [message] = messages
    assert message.startswith(f"{path}, line 1801")
    assert needle in message
    # the piecewise readers leave the file to the whole reader, which words the fault
    assert correct_record_file(path, MODEL, block_bytes=SMALL) is None
    assert open_record_stream(path, block_bytes=SMALL).scan() is None


def test_a_file_not_to_stream_says_why_before_any_piece(tmp_path):
    gz = tmp_path / "rec.csv.gz"
    gz.write_bytes(b"\x1f\x8b")
    comments = tmp_path / "comments.csv"
    comments.write_text("# a: b\n")
    for path, why in ((gz, "'.gz' file"), (comments, "header"), (tmp_path / "none.csv", "not a file")):
        stream = open_record_stream(path)
        assert why in stream.whole_reason and list(stream) == [] and stream.scan() is None
    with pytest.raises(InputError, match="missing required column 'signal'"):
        (tmp_path / "two.csv").write_text("time,load\n0,1\n")
        open_record_stream(tmp_path / "two.csv")


def test_correct_in_pieces_leaves_no_output_when_the_file_grows_between_passes(tmp_path):
    from creepcomp.digital.record_file import correct_record_file

    t, load, signal = _staircase(3000)
    path = write_record(tmp_path / "rec.csv", Record(t, load, signal))

    def append_rows_after_the_first_pass(done, rows=None, description=None):
        if description == "correcting":
            with path.open("a") as fh:
                fh.write("1000,0,0\n1001,0,0\n")

    out = tmp_path / "out.csv"
    assert correct_record_file(path, MODEL, output=out, progress=append_rows_after_the_first_pass,
                               block_bytes=SMALL) is None
    assert sorted(p.name for p in tmp_path.iterdir()) == ["rec.csv"]


def test_a_discarded_record_writer_leaves_no_file(tmp_path):
    out = tmp_path / "out.csv"
    with record_writer(out, ["time", "load"], {}) as write:
        write({"time": np.arange(3.0), "load": np.zeros(3)})
        write.discard()
    assert list(tmp_path.iterdir()) == []
    with record_writer(out, ["time", "load"], {"k": "v"}) as write:
        write({"time": np.arange(3.0), "load": np.zeros(3)})
    assert out.read_text().splitlines()[:3] == ["# k: v", "time,load", "0,0"]
