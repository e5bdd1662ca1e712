"""Fuzz: random and mutated record and design files give exit 0 or 2 with one line on
stderr, never a traceback, never a partial output file."""

import contextlib
import io
from pathlib import Path

from hypothesis import HealthCheck, given, settings, strategies as st

from creepcomp.cli import main

DATA = Path(__file__).resolve().parents[1] / "src" / "creepcomp" / "data"
VALID_RECORD = (DATA / "hidden_effect.csv").read_bytes()[:1500]
VALID_DESIGN = (DATA / "built_network.design.json").read_bytes()


def mutated(valid: bytes):
    """A valid file with a slice replaced by random bytes, or random bytes alone."""
    edit = st.tuples(st.integers(0, len(valid)), st.integers(0, 40), st.binary(max_size=40))
    return st.one_of(st.binary(max_size=300),
                     edit.map(lambda e: valid[:e[0]] + e[2] + valid[e[0] + e[1]:]))


def run(tmp: Path, *args) -> tuple[int, str]:
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        status = main([str(a) for a in args])
    return status, err.getvalue()


def check(tmp: Path, status: int, err: str, outputs) -> None:
    assert status in (0, 2), err
    assert "Traceback" not in err
    errors = [line for line in err.splitlines() if line.startswith("creepcomp: error")]
    assert len(errors) == (1 if status == 2 else 0), err
    if status == 2:
        assert all(not p.exists() for p in outputs), "output written by a failed run"
    assert not list(tmp.glob(".*.part")), "a partial file is left"


@settings(max_examples=40, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(data=mutated(VALID_RECORD))
def test_fuzzed_records(tmp_path, data):
    rec = tmp_path / "r.csv"
    rec.write_bytes(data)
    model = tmp_path / "m.json"
    model.write_text('{"beta": [0.03], "tau": [45.0], "gain": 1.0, "offset": 0.0}')
    out = tmp_path / "out.csv"
    out.unlink(missing_ok=True)
    status, err = run(tmp_path, "correct", rec, "--model", model, "-o", out)
    check(tmp_path, status, err, [out])


@settings(max_examples=40, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(data=mutated(VALID_DESIGN))
def test_fuzzed_designs(tmp_path, data):
    design = tmp_path / "d.json"
    design.write_bytes(data)
    out = tmp_path / "n.cir"
    out.unlink(missing_ok=True)
    status, err = run(tmp_path, "netlist", design, "-o", out)
    check(tmp_path, status, err, [out])
