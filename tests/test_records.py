from pathlib import Path

import numpy as np
import pytest

from creepcomp.errors import InputError
from creepcomp.io.records import Record, parse_columns, parse_record, read_record, write_record



def test_reads_metadata_case_insensitive_columns_and_optional_ones():
    text = ("# units.load: g\n# design: net.json\nTime,LOAD,Signal,temperature,corrected,extra\n"
            "10.0,0,0.1,25,0.1,x\n10.5,1,1.1,25.1,1.0,y\n12.0,1,1.2,25.2,1.0,z\n")
    r = parse_record(text, "r.csv")
    assert len(r) == 3 and r.time[0] == 10.0 and r.unit("load") == "g"
    assert r.temperature is not None and r.corrected is not None
    assert r.design_path() == Path("net.json")
    assert r.design_path("other.json") == Path("other.json")
    assert not r.is_uniform


@pytest.mark.parametrize("text,needle", [
    ("time,load\n0,1\n", "missing required column 'signal'; columns found: time, load"),
    ("time,load,signal\n0,1,2\n1,x,3\n", "line 3, column 'load': 'x' is not a number"),
    ("time,load,signal\n0,1,2\n1,inf,3\n", "line 3, column 'load': 'inf' is not a finite"),
    ("time,load,signal\n0,1,2\n1,1,nan\n", "line 3, column 'signal': 'nan'"),
    ("time,load,signal\n0,1,2\n0,1,3\n", "line 3, column 'time': 0 repeats"),
    ("time,load,signal\n0,1,2\n2,1,2\n1,1,3\n", "line 4, column 'time': 1 is earlier"),
    ("time,load,signal\n", "no data rows"),
    ("# only: comments\n", "no header"),
])
def test_bad_records_name_file_line_and_column(text, needle):
    with pytest.raises(InputError, match="bad.csv") as info:
        parse_record(text, "bad.csv")
    assert needle in str(info.value)


def test_corrected_without_design_is_reported():
    r = parse_record("time,load,signal,corrected\n0,0,0,0\n1,1,1,1\n", "r.csv")
    with pytest.raises(InputError, match="names no design"):
        r.design_path()


def test_too_short_records_are_reported():
    r = parse_record("time,load,signal\n0,0,0\n1,1,1\n", "r.csv")
    with pytest.raises(InputError, match="2 samples is too few for fitting"):
        r.require(10, what="fitting")
    with pytest.raises(InputError, match="spans 1 s, shorter than the 450 s"):
        r.require(2, duration=450.0, what="a 45 s retardation time")


def _rounded_stamps_export(path):
    """A rheometer-like CSV: time stamps rounded so that rows 5 and 6 (lines 6, 7) share one."""
    t = [0.5, 1.0, 2.0, 3.0, 4.0, 4.0, 5.0, 6.0]
    rows = "".join(f"{x},{1e-6 * (1 + 0.01 * i):.9g},{i}\n" for i, x in enumerate(t))
    path.write_text("Time,Creep Compliance,Step\n" + rows)
    return path


def test_column_mapping_and_constant_load_for_a_creep_export(tmp_path):
    p = _rounded_stamps_export(tmp_path / "creep.csv")
    cols = parse_columns("time=Time,signal=Creep Compliance,load=1")
    with pytest.raises(InputError, match="line 7, column 'time': 4 repeats"):
        read_record(p, cols)
    r = read_record(p, cols, duplicate_times="mean")
    assert r.metadata["merged_duplicate_times"] == "1" and len(r) == 7
    assert np.all(r.load == 1.0) and r.signal[0] == pytest.approx(1e-6)
    assert r.signal[4] == pytest.approx(1e-6 * (1 + 0.01 * 4.5))      # rows sharing t = 4 averaged


def trios_like_export(time_min, strain_percent, stress_mpa) -> str:
    """Text laid out as a rheometer's tab-separated export: a preamble of blocks, a header of
    long column names, a units row, then the data."""
    lines = ["Filename\tcreep.txt", "Instrument name\tRHEOMETER", "[File Parameters]",
             "Name\tcreep", "[Geometry Parameters]", "Diameter\t8.0 mm", "", "[step]",
             "Creep", "Time\tStep time\tStrain\tStress\tTemperature",
             "s\tmin\t%\tMPa\t°C"]
    lines += [f"{60 * t:.6g}\t{t:.9g}\t{e:.9g}\t{stress_mpa:.9g}\t25" for t, e in zip(time_min, strain_percent)]
    return "\n".join(lines) + "\n"


def test_instrument_export_with_preamble_and_units_row():
    t = np.linspace(0.01, 2.9, 40)
    r = parse_record(trios_like_export(t, 0.5 + 0.01 * t, 0.2), "creep.txt",
                     parse_columns("time=Step time,signal=Strain,load=Stress"))
    assert len(r) == 40
    assert r.time[-1] == pytest.approx(2.9 * 60, rel=1e-9)      # minutes -> seconds
    assert r.unit("load") == "MPa" and r.unit("signal") == "%"
    assert r.unit("time").startswith("s (converted from min")


@pytest.mark.parametrize("text,needle", [
    ("time=a,signal", "not NAME=COLUMN"), ("speed=a", "not a record column"), ("time=", "no column"),
])
def test_bad_column_mapping(text, needle):
    with pytest.raises(InputError, match=needle):
        parse_columns(text)


def test_write_and_read_back_exactly(tmp_path):
    rng = np.random.default_rng(0)
    t = np.cumsum(rng.uniform(0.01, 1, 50))
    r = Record(t, rng.normal(size=50), rng.normal(size=50), metadata={"units.load": "N"})
    p = write_record(tmp_path / "o.csv", r, extra={"compensated": r.signal * 2})
    back = read_record(p)
    np.testing.assert_array_equal(back.time, r.time)
    np.testing.assert_array_equal(back.signal, r.signal)
    assert back.unit("load") == "N"
    assert "compensated" in p.read_text().splitlines()[1]


def test_the_record_rules_and_their_messages_live_in_one_module():
    import creepcomp.io.record_check as check
    import creepcomp.io.records as records

    rules = Path(check.__file__).read_text(encoding="utf-8")
    readers = Path(records.__file__).read_text(encoding="utf-8")
    for phrase in ("is not a number", "is not a finite number", "time must be strictly increasing",
                   "missing required column", "is not one of", "no data rows", "no header line",
                   "(the row has"):
        assert phrase in rules and phrase not in readers, phrase


def test_a_mapped_column_is_read_or_constant():
    from creepcomp.io.record_check import resolve_columns

    cols = resolve_columns(["Time", "Out", "Temp"], {"time": "Time", "signal": "out", "load": "2.5"},
                           "r.csv", 0)
    assert cols.read == {"time": 0, "signal": 1} and cols.constants == {"load": 2.5}
    # a number that names a column of the file is that column, not a constant
    cols = resolve_columns(["time", "1", "signal"], {"load": "1"}, "r.csv", 0)
    assert cols.read == {"time": 0, "load": 1, "signal": 2} and cols.constants == {}


def test_an_unknown_time_unit_is_reported_before_the_cells(tmp_path):
    text = "Step time,Force,Out\nyears,N,V\n0,1,1\n1,x,1\n"
    cols = {"time": "Step time", "load": "Force", "signal": "Out"}
    path = tmp_path / "units.csv"
    path.write_text(text)
    for read in (lambda: parse_record(text, str(path), cols), lambda: read_record(path, cols)):
        with pytest.raises(InputError, match=r"units.csv: time unit 'years' is not one of s, sec"):
            read()


def test_a_file_that_cannot_be_read_is_reported_with_its_cause(tmp_path, monkeypatch):
    from creepcomp.io.records import open_record_stream

    path = tmp_path / "locked.csv"
    path.write_text("time,load,signal\n0,0,0\n1,1,1\n")
    real_open = Path.open

    def refusing_open(self, *args, **kwargs):
        if self.name == "locked.csv":
            raise PermissionError(13, "Permission denied", str(self))
        return real_open(self, *args, **kwargs)

    monkeypatch.setattr(Path, "open", refusing_open)
    for read in (read_record, open_record_stream):
        with pytest.raises(InputError) as info:
            read(path)
        assert str(info.value) == f"record {path}: cannot read it (Permission denied)"
