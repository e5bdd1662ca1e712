"""The held-out load error benchmark's protocol (``benchmarks/real_load_error.py``): the split,
the error's scale, failures kept in their cells, refused model files counted, the summary."""

import importlib.util
import json
import sys
from pathlib import Path

import numpy as np
import pytest

from creepcomp.errors import InputError
from creepcomp.io.records import Record

pytest.importorskip("sklearn", reason="the static monotone calibration needs scikit-learn (bench extra)")
pytest.importorskip("sysidentpy", reason="the NARX peer needs sysidentpy (bench extra)")

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
import real_load_error as bench  # noqa: E402

RECOMMENDED_MISSING = importlib.util.find_spec("creepcomp.fit.signal_path") is None


def _pad_record(start=0.0) -> Record:
    """Presses on a saturating pad (the reading falls, then levels off) with a little creep."""
    t = start + np.arange(0.0, 200.0, 0.2)
    load = np.where((t - start) % 20 < 8, 1.0 + 0.5 * np.sin(t - start) ** 2, 0.0)
    strain = load * (1 + 0.05 * (1 - np.exp(-((t - start) % 20) / 3.0)) * (load > 0))
    signal = 1.0 / (0.2 + strain) + np.random.default_rng(1).normal(0, 1e-3, t.size)
    return Record(t, load, signal, source="pad")


def test_the_split_is_at_sixty_percent_of_the_time_whatever_the_clock():
    for start in (0.0, 1.75e9):
        r = _pad_record(start)
        k = bench.split_index(r)
        assert r.time[k - 1] < r.time[0] + 0.6 * r.duration <= r.time[k]


def test_the_error_is_rms_over_the_held_out_part_in_percent_of_the_whole_load_range():
    r = _pad_record()
    k = bench.split_index(r)
    estimate = r.load.copy()
    estimate[k:] += 0.03
    estimate[:k] += 10.0                   # the training part does not count
    assert bench.heldout_error(r, estimate, k) == pytest.approx(100 * 0.03 / np.ptp(r.load))
    with pytest.raises(FloatingPointError):
        bench.heldout_error(r, np.full(len(r), np.nan), k)


@pytest.mark.slow
def test_every_column_of_a_record_and_a_monotone_curve_beating_a_line_on_a_saturating_pad():
    out = bench.run_record("pad", _pad_record(), {"most": 400, "lags": ((0, 1), (1, 1)), "info_values": 4})
    cells = out.cells
    assert list(cells) == list(bench.METHODS)
    assert cells["static monotone"].error < cells["static line"].error
    assert cells["NARX"].error is not None and cells["NARX"].note.startswith("lags (y, u)")
    if RECOMMENDED_MISSING:
        assert cells["recommended"].note == bench.NOT_AVAILABLE
        assert "recommended" not in out.refused
    assert "baseline" in out.refused          # fit wrote a model file, read back and checked


class _FakeFit:
    """What fit_prony returns, for a record whose model file correct refuses."""

    def to_dict(self):
        return {"beta": [-2.0], "tau": [10.0], "gain": 1.0, "offset": 0.0}

    def model(self):
        raise InputError("beta0 = -2: beta0 must be greater than -1")


@pytest.mark.slow
def test_a_failing_creepcomp_call_fills_its_cell_and_a_refused_file_is_counted(monkeypatch):
    import creepcomp.fit.prony

    monkeypatch.setattr(creepcomp.fit.prony, "fit_prony", lambda data, **kw: _FakeFit())
    out = bench.run_record("pad", _pad_record(), {"most": 400, "lags": ((0, 1),), "info_values": 4})
    assert out.cells["baseline"].note == "failed: beta0 = -2: beta0 must be greater than -1"
    assert out.cells["baseline"].error is None
    assert "beta0" in out.refused["baseline"] and "/tmp" not in out.refused["baseline"]
    summ = bench.summary([out])
    assert summ["model_files_refused"]["baseline"] == 1
    assert summ["columns"]["baseline"]["failed"] == 1
    assert "failed: beta0 = -2" in bench.markdown([out], summ)


def test_the_summary_counts_the_recommended_against_the_best_static_and_narx():
    def outcome(line, mono, narx, rec):
        cells = {m: bench.Cell(e) for m, e in zip(bench.METHODS, (line, mono, narx, 5.0, rec))}
        return bench.Outcome("r", 10, cells, {})

    summ = bench.summary([outcome(4.0, 3.0, 2.0, 2.5), outcome(4.0, 3.0, 3.5, 3.0),
                          outcome(1.0, 3.0, 9.0, 1.5)])
    assert summ["recommended_at_most_best_static"] == 2
    assert summ["recommended_at_most_narx"] == 2
    assert summ["columns"]["recommended"]["median_error_percent"] == 2.5


def test_the_command_prints_json_and_writes_one_plot_per_kind(tmp_path, capsys):
    code = bench.main(["--no-shipped", "--soft", "2", "--quick", "--max-samples", "300", "--json",
                       "--plots", str(tmp_path / "plots")])
    assert code == 0
    result = json.loads(capsys.readouterr().out)
    assert [r["record"].split()[0] for r in result["records"]] == ["fsr", "velostat"]
    assert result["summary"]["records"] == 2
    assert [r["truth"]["kind"] for r in result["records"]] == ["fsr", "velostat"]
    assert len(list((tmp_path / "plots").glob("*.png"))) == 2


@pytest.mark.slow
def test_a_record_file_is_read_as_creepcomp_reads_it(tmp_path, capsys):
    from creepcomp.io.records import write_record

    path = write_record(tmp_path / "pad.csv", _pad_record(1.0e5))
    assert bench.main(["--no-shipped", "--soft", "0", "--quick", "--json", "--record", str(path)]) == 0
    [row] = json.loads(capsys.readouterr().out)["records"]
    assert row["record"] == "pad.csv" and row["samples"] == 1000
    assert row["cells"]["static monotone"]["error_percent"] < row["cells"]["static line"]["error_percent"]


def test_bad_options_exit_2_with_one_message(tmp_path, capsys):
    assert bench.main(["--no-shipped", "--soft", "0", "--insole", str(tmp_path / "none.mat")]) == 2
    assert "--insole" in capsys.readouterr().err
    assert bench.main(["--no-shipped", "--soft", "0", "--record", str(tmp_path / "none.csv")]) == 2
    assert "--record" in capsys.readouterr().err
    from creepcomp.io.records import write_record

    r = _pad_record()
    held = write_record(tmp_path / "held.csv", Record(r.time, np.ones(len(r)), r.signal))
    assert bench.main(["--no-shipped", "--soft", "0", "--record", str(held)]) == 2
    assert "the load does not change" in capsys.readouterr().err


def test_a_record_given_twice_is_run_once(capsys):
    r = _pad_record()
    other = Record(r.time, r.load, r.signal + 1.0)
    kept = bench._distinct([("shipped", r), ("from its file", r), ("other", other)], quiet=False)
    assert [name for name, _ in kept] == ["shipped", "other"]
    assert "from its file: the same data as shipped, left out" in capsys.readouterr().err
