"""Records from anywhere: a path, an open file, a data frame (pandas, polars, pyarrow, any
object with named columns) or a mapping of arrays, matched and checked as a file is; the API
entries that take a record take each of them; a wrong type is named."""

import io
import re

import numpy as np
import pytest

import creepcomp
from creepcomp import data, read_record
from creepcomp.errors import InputError
from creepcomp.io.formats import read_any


@pytest.fixture(scope="module")
def bundled():
    return data.hidden_effect()


def same_columns(a, b):
    for name in ("time", "load", "signal"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name))


class Frame:
    """Any object with named columns: ``columns`` and ``frame[name]``, and nothing else."""

    def __init__(self, columns):
        self._columns = dict(columns)
        self.columns = list(self._columns)

    def __getitem__(self, name):
        return self._columns[name]


def as_pandas(record):
    pd = pytest.importorskip("pandas")
    return pd.DataFrame({"Time": record.time, "LOAD": record.load, "Signal": record.signal})


def as_polars(record):
    pl = pytest.importorskip("polars")
    return pl.DataFrame({"time": record.time, "load": record.load, "signal": record.signal})


def as_arrow(record):
    import pyarrow as pa

    return pa.table(record.columns())


def as_structured(record):
    out = np.zeros(len(record), dtype=[("time", float), ("load", float), ("signal", float)])
    for name in ("time", "load", "signal"):
        out[name] = getattr(record, name)
    return out


@pytest.mark.parametrize("convert", [lambda r: r.columns(), lambda r: Frame(r.columns()),
                                     as_pandas, as_polars, as_arrow, as_structured],
                         ids=["mapping", "duck-frame", "pandas", "polars", "pyarrow", "structured"])
def test_columns_in_memory_read_as_the_file(bundled, convert):
    record = read_record(convert(bundled))
    same_columns(record, bundled)
    assert record.temperature is None and record.corrected is None


def test_open_files_text_and_bytes_read_as_the_path(bundled):
    path = data.path("hidden_effect.csv")
    with open(path, encoding="utf-8") as text, open(path, "rb") as raw:
        for fh in (text, raw):
            record = read_record(fh)
            same_columns(record, bundled)
            assert record.metadata == bundled.metadata
            assert record.source == str(path)


def test_a_record_passes_through_and_metadata_is_added(bundled):
    assert read_record(bundled) is bundled
    record = read_record(bundled.columns(), metadata={"units.signal": "V"})
    assert record.unit("signal") == "V"


def test_a_column_mapping_and_a_constant_apply_to_frames():
    t = np.arange(4.0)
    record = read_record(Frame({"tR": t, "Ri": 2 * t}), columns={"time": "tR", "signal": "Ri",
                                                                  "load": "1.5"})
    np.testing.assert_array_equal(record.load, np.full(4, 1.5))
    np.testing.assert_array_equal(record.signal, 2 * t)


@pytest.mark.parametrize("columns, message", [
    ({"time": [0.0, 1.0, 1.0], "load": [1, 1, 1], "signal": [0, 1, 2]},
     "dict: time is not strictly increasing: sample 2 (1 s) repeats"),
    ({"time": [0.0, 1.0, 2.0], "load": [1, np.nan, 1], "signal": [0, 1, 2]},
     "dict: column 'load', sample 1: nan is not a finite number"),
    ({"time": [0.0, 1.0, 2.0], "signal": [0, 1, 2]},
     "dict: missing required column 'load'; columns found: time, signal"),
    ({"time": [0.0, 1.0, 2.0], "load": ["a", "b", "c"], "signal": [0, 1, 2]},
     "dict: column 'load' holds text (<U1), not numbers"),
    ({"time": [0.0, 1.0, 2.0], "load": [True, False, True], "signal": [0, 1, 2]},
     "dict: column 'load' holds booleans (bool), not numbers"),
    ({"time": [0.0, 1.0, 2.0], "load": [1, 1], "signal": [0, 1, 2]},
     "dict: column 'load' has 2 values for 3 time points"),
    ({"time": [0.0, 1.0], "load": 1.0, "signal": [0, 1]},
     "dict: column 'load' is a single value, not one value per sample"),
    ({"time": [], "load": [], "signal": []}, "dict: no rows"),
    ({"TIME": [0.0], "time": [1.0], "load": [1], "signal": [0]},
     "dict: columns 'TIME' and 'time' are the same column"),
])
def test_faults_of_columns_in_memory_are_named(columns, message):
    with pytest.raises(InputError, match="^" + message.replace("(", r"\(").replace(")", r"\)")):
        read_record(columns)


def test_nothing_is_converted_silently():
    pd = pytest.importorskip("pandas")
    frame = pd.DataFrame({"time": pd.date_range("2024-01-01", periods=3, freq="s"),
                          "load": [0.0, 1.0, 1.0], "signal": [0.0, 1.0, 1.0]})
    with pytest.raises(InputError, match="column 'time' holds dates or durations"):
        read_record(frame)
    with pytest.raises(InputError, match="'time' is the frame's index: use frame.reset_index()"):
        read_record(frame.assign(time=[0.0, 1.0, 2.0]).set_index("time"))
    nullable = pd.DataFrame({"time": [0.0, 1.0, 2.0], "load": pd.array([1.0, None, 1.0], dtype="Float64"),
                             "signal": [0.0, 1.0, 2.0]})
    with pytest.raises(InputError, match="column 'load', sample 1"):
        read_record(nullable)
    mean = read_record({"time": [0.0, 1.0, 1.0], "load": [1, 1, 1], "signal": [0, 1, 2]},
                       duplicate_times="mean")
    assert mean.metadata["merged_duplicate_times"] == "1" and list(mean.signal) == [0.0, 1.5]


@pytest.mark.parametrize("thing", [np.zeros((3, 3)), 42, None, [1.0, 2.0]])
def test_a_wrong_type_is_named(thing):
    with pytest.raises(InputError, match=f"record: a .*{type(thing).__qualname__} is not a record"):
        read_record(thing)


def test_a_frame_that_gives_no_column_is_named():
    class Lazy:
        columns = ["time", "load", "signal"]

        def __getitem__(self, name):
            raise TypeError("not subscriptable\nuse collect() first")

    with pytest.raises(InputError, match=r"^Lazy: cannot take its column 'time' as an array "
                                         r"\(TypeError: not subscriptable\)$"):
        read_record(Lazy())


def test_a_delimiter_or_taxel_for_columns_in_memory_is_refused(bundled):
    with pytest.raises(InputError, match="a delimiter is for text"):
        read_record(bundled.columns(), delimiter=";")
    with pytest.raises(InputError, match="a taxel or a sheet applies to .mat or .xlsx files only"):
        read_any(bundled.columns(), taxel=3)


@pytest.mark.parametrize("content, message", [
    ("time,load,signal\n0,0,0\n0,1,1\n", "open file, line 3, column 'time': 0 repeats the previous time"),
    (b"time,load,signal\n0,0,0\n1,1,\xff\n", "record open file: not UTF-8 text (invalid start byte at byte 27)"),
    ("time,load\n0,0\n", "open file, line 1: missing required column 'signal'"),
])
def test_faults_of_an_open_file_are_named_as_a_file_s(content, message):
    fh = io.BytesIO(content) if isinstance(content, bytes) else io.StringIO(content)
    with pytest.raises(InputError, match="^" + re.escape(message)):
        read_record(fh)


def test_gzip_bytes_in_an_open_file_are_named():
    with pytest.raises(InputError, match="gzip-compressed"):
        read_record(io.BytesIO(b"\x1f\x8b\x08\x00"))


@pytest.mark.parametrize("first", ["import creepcomp.diagnose.sensor, creepcomp.fit.prony",
                                   "import creepcomp; creepcomp.fit; creepcomp.diagnose",
                                   "from creepcomp import fit, diagnose"])
def test_fit_and_diagnose_are_subpackages_that_call_their_functions(first):
    import subprocess
    import sys

    check = """
import inspect
import creepcomp
import creepcomp.fit.prony as prony
import creepcomp.diagnose.sensor as sensor
from creepcomp import diagnose, fit
from creepcomp.diagnose.fitting import fit as fit_function
assert creepcomp.fit is fit and creepcomp.diagnose is diagnose
assert fit.prony is prony and diagnose.sensor is sensor and diagnose.diagnose is sensor.diagnose
assert inspect.signature(fit) == inspect.signature(fit_function)
try:
    diagnose(7)
except creepcomp.InputError as exc:
    assert "builtins.int is not a record" in str(exc)
else:
    raise AssertionError("no InputError")
print("ok")
"""
    done = subprocess.run([sys.executable, "-c", first + "\n" + check], capture_output=True,
                          text=True, timeout=120)
    assert done.returncode == 0 and done.stdout.strip() == "ok", done.stderr


def test_fit_takes_a_frame_and_fits_as_the_command_does(bundled, run_cli):
    import json

    result = creepcomp.fit(Frame(bundled.columns()), max_terms=2)
    status, out, _ = run_cli("fit", data.path("hidden_effect.csv"), "--max-terms", "2", "--json")
    assert status == 0
    command = json.loads(out)
    model = result.to_dict()
    for key in ("beta", "tau", "gain", "offset", "uncertainty"):
        assert model[key] == command[key]


def test_diagnose_correct_and_prepare_take_frames(bundled):
    from creepcomp.fit import prepare

    prepared = prepare(Frame(bundled.columns()))
    np.testing.assert_array_equal(prepared.signal, bundled.signal)
    model = creepcomp.CreepModel.voigt(0.03, 45.0)
    from_frame = creepcomp.correct_record(Frame(bundled.columns()), model)
    np.testing.assert_array_equal(from_frame.compensated,
                                  creepcomp.correct_record(bundled, model).compensated)
    with pytest.raises(InputError, match="record: a builtins.int is not a record"):
        creepcomp.diagnose(7)
    with pytest.raises(InputError, match="record: a builtins.str is not a record|no such file"):
        creepcomp.fit("no-such-record.csv")


def test_fit_takes_the_commands_reader_options(bundled, tmp_path):
    text = data.path("hidden_effect.csv").read_text().replace(",", ";")
    (tmp_path / "semicolons.csv").write_text(text)
    model = creepcomp.fit(tmp_path / "semicolons.csv", delimiter=";", max_terms=1).model()
    assert model == creepcomp.fit(bundled, max_terms=1).model()
    with pytest.raises(InputError, match="a taxel applies to insole .mat files only"):
        creepcomp.fit(tmp_path / "semicolons.csv", taxel=3)
