"""ngspice netlists, shared-ngspice runs and their agreement with python-control."""

import math
import re
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from creepcomp.verify import compare, drive, netlist, ngspice_engine
from creepcomp.data import default_sensor
from creepcomp.errors import InputError
from creepcomp.model import CreepModel
from creepcomp.network import Branch, Cell, Network
from creepcomp.programs import LoadProgram, staircase, step
from creepcomp.analog.quality import predict
from creepcomp.analog.sizing import ideal_network

REPO = Path(__file__).resolve().parents[1]
PAPER_FINAL = 0.03 ** 2 / 1.06                       # beta0^2 / (1 + 2 beta0), physics.md
PAPER_PEAK = PAPER_FINAL * (1 + math.exp(-2))        # at t = 2 tau


@pytest.fixture(scope="module")
def default():
    model = default_sensor()
    return model, {rule: ideal_network(model, rule, 10e-6) for rule in ("paper", "exact")}


# --- programs and time points ---------------------------------------------------------------

def test_transient_times_are_uniform_between_breakpoints_and_hit_them():
    prog = drive.spice_program(staircase((1, 3, 0), hold=100.0), default_sensor(),
                               ideal_network(default_sensor(), "exact", 10e-6))
    t = drive.transient_times(prog, 400.0, 200)
    edges = drive.program_breakpoints(prog, 400.0)
    assert set(edges) <= set(t) and t[0] == 0 and t[-1] == 400.0
    assert np.diff(t).max() <= 400.0 / 200 * (1 + 1e-9)
    for a, b in zip(edges[:-1], edges[1:]):
        seg = np.diff(t[(t >= a) & (t <= b)])
        assert np.ptp(seg) <= 1e-9 * seg.mean()


def test_steps_become_short_ramps_normalised_and_rounded_as_printed():
    model = default_sensor()
    net = ideal_network(model, "paper", 10e-6)
    prog = drive.spice_program(staircase((2.0, 4.0, 1.0), hold=100.0), model, net)
    assert max(prog.loads) == 1.0 and prog.loads[1] == 0.5
    assert np.all(np.diff(prog.times) > 0)                         # no repeated time left
    assert prog.times[1] == pytest.approx(1e-5)                    # 1e-6 of ~45 s, power of ten
    assert all(float(drive.spice_number(t)) == t for t in prog.times + prog.loads)
    assert drive.ramped(step(1.0, at=5.0), 0.1).times == (5.0, 5.1)
    with pytest.raises(InputError, match="does not fit"):
        drive.ramped(LoadProgram((0, 0, 1e-3), (0, 1, 1)), 1.0)
    with pytest.raises(InputError, match="zero throughout"):
        drive.spice_program(LoadProgram((0, 1), (0, 0)), model, net)
    with pytest.raises(InputError, match="starts at"):
        drive.spice_program(step(1.0, at=-1.0), model, net)


def test_default_durations_settle_a_step_and_keep_a_program():
    model = default_sensor()
    assert drive.default_duration(drive.synthetic_program(model, "step"), model) == 900.0
    stair = drive.synthetic_program(model, "staircase")
    assert drive.default_duration(stair, model) == stair.end == 6 * 230.0
    sweep = drive.synthetic_program(model, "sweep")
    assert sweep.end == pytest.approx(3 * 2 * math.pi * 45.0)
    with pytest.raises(InputError, match="program 'ramp'"):
        drive.synthetic_program(model, "ramp")


# --- netlist text ---------------------------------------------------------------------------

def test_netlist_holds_the_whole_experiment_in_few_lines():
    model = CreepModel((0.01, -0.004), (5.0, 50.0))
    net = Network((Cell(1e6, 5e-6, leakage=1e12, absorption_R=1e9, absorption_C=1e-8),
                   Cell(2e5, 0.0)), 3e7, (Branch(4e6, 1e-6),), 470.0, 1e9)
    deck = netlist.program_deck(net, model, staircase(hold=50.0), 300.0, 1000, 1e-4)
    text = deck.text()
    for line in ("Eins ins 0 load 0 0.0001", "Ccreep1 creep1 0 5", "Ccreep2 creep2 0 50",
                 "Bsensor emf 0 v=V(ins) + 0.01*V(creep1) - 0.004*V(creep2)",
                 "Rs emf sensor 470", "R1_1 sensor n1 1000000", "C1_1 sensor n1 5e-06",
                 "Rleak_1 sensor n1 1e+12", "Rda_1 sensor da1 1000000000", "Cda_1 da1 n1 1e-08",
                 "R1_2 n1 out 200000", "R2 out 0 30000000", "R3 out s1 4000000",
                 "C3 s1 0 1e-06", "RL out 0 1000000000", ".tran 0.3 300 0 0.15", ".end"):
        assert line in text, line
    assert "C1_2" not in text                                       # C = 0: a plain resistor
    assert text.isascii() and "/" not in text.split(".control")[0].replace("+/-", "")
    assert len(text) < 3000
    assert ".control" not in deck.text(standalone=False)


def test_record_netlist_stays_small_for_a_long_record():
    n = 100_000
    t = np.arange(n) * 0.01
    signal = 1e-4 * (t > 100) + 1e-9 * np.sin(t)
    deck = netlist.record_deck(ideal_network(default_sensor(), "exact", 10e-6), t, signal, "r.txt")
    text = deck.text()
    assert len(text.encode()) < 2000 and "PWL" not in text
    assert 'filesource' in text and 'file="r.txt"' in text
    assert deck.tran[0] == pytest.approx(0.01) and deck.tran[2] == pytest.approx(0.005)
    data = netlist.record_data(t + 50.0, signal)
    assert data.count("\n") == n + 1 and data.startswith("0 0\n")
    last, hold = (np.array(line.split(), float) for line in data.splitlines()[-2:])
    assert last == pytest.approx([t[-1], signal[-1]]) and hold == pytest.approx([t[-1] + 0.01, signal[-1]])
    with pytest.raises(InputError, match="constant"):
        netlist.record_deck(Network((Cell(1e6, 1e-5),), 1e7), t, np.zeros(n))


# --- ngspice against python-control ---------------------------------------------------------

@pytest.mark.parametrize("program", drive.PROGRAMS)
@pytest.mark.parametrize("rule", ["paper", "exact"])
def test_default_design_agrees_to_1e6_of_the_step(default, rule, program):
    model, nets = default
    c = compare.compare_program(nets[rule], model, program)
    assert c.spice is not None and c.unavailable is None
    assert c.agreement_max_abs < 1e-6
    assert c.agreement_output < 1e-7
    if program == "step":
        if rule == "paper":
            assert c.residual_creep_final == pytest.approx(PAPER_FINAL, rel=1e-5)
            assert c.residual_creep_peak == pytest.approx(PAPER_PEAK, rel=1e-4)
        else:
            assert c.residual_creep_peak < 1e-10


def test_python_control_reference_is_the_closed_form(default):
    model, nets = default
    c = compare.compare_program(nets["paper"], model, "step", engine=None)
    t = c.reference.time
    x = np.clip(t - 1e-5, 0, None) / 45.0           # the step is a 10 us ramp
    closed = PAPER_FINAL * (1 - np.exp(-x) + x * np.exp(-x))
    np.testing.assert_allclose(c.residual("reference")[t > 1e-3], closed[t > 1e-3], atol=1e-9)
    assert predict(model, nets["paper"]).residual_creep_peak == pytest.approx(
        c._residual_figures("reference")[0], rel=1e-4)


def test_agreement_does_not_depend_on_the_signal_level(default):
    model, nets = default
    small = compare.compare_program(nets["paper"], model, "staircase", signal=100e-6)
    large = compare.compare_program(nets["paper"], model, "staircase", signal=1.0)
    tiny = compare.compare_program(nets["paper"], model, "staircase", signal=1e-7)
    for c in (small, large, tiny):
        assert c.agreement_max_abs < 1e-6
    np.testing.assert_allclose(small.residual(), large.residual(), atol=1e-8)
    np.testing.assert_allclose(tiny.residual(), large.residual(), atol=1e-8)


@pytest.mark.parametrize("stem", ["foster3-exact", "negative-lag"])
@pytest.mark.parametrize("program", ["step", "staircase"])
def test_multi_term_and_lag_designs_agree(stem, program):
    design, _ = netlist.reference_designs()[stem]
    c = compare.compare_program(design.network, design.model, program)
    assert c.agreement_max_abs < 1e-6
    assert c.residual_creep_peak < 1e-9                 # exact designs: nothing left


def test_source_load_resistance_and_imperfect_capacitor_agree():
    model = default_sensor()
    base = ideal_network(model, "exact", 10e-6, source_resistance=2e3, load_resistance=1e10)
    cell = base.cells[0]
    net = Network((Cell(cell.R, cell.C, leakage=1e10, absorption_R=2e9, absorption_C=2e-7),),
                  base.R2, (), base.source_resistance, base.load_resistance)
    c = compare.compare_program(net, model, "step")
    assert c.agreement_max_abs < 1e-6
    assert c.residual_creep_peak > 1e-5                 # leakage and absorption show up ...
    assert c.residual_creep_peak == pytest.approx(c._residual_figures("reference")[0], rel=1e-4)
    ideal = compare.compare_program(base, model, "step")   # ... and without them it cancels
    assert ideal.residual_creep_peak < 1e-10


@settings(max_examples=12)
@given(st.floats(0.005, 0.1), st.floats(2.0, 300.0), st.floats(0.8, 1.25), st.floats(0.8, 1.25))
def test_random_one_term_designs_agree(beta, tau, f1, f2):
    model = CreepModel.voigt(beta, tau)
    ideal = ideal_network(model, "exact", 4.7e-6)
    net = Network((Cell(ideal.cells[0].R * f1, ideal.cells[0].C),), ideal.R2 * f2)
    c = compare.compare_program(net, model, "step", points=500)
    assert c.agreement_max_abs < 1e-6


def test_record_drive_agrees_on_ngspice_time_points():
    model = default_sensor()
    net = ideal_network(model, "paper", 10e-6)
    rng = np.random.default_rng(3)
    t = 10.0 + np.cumsum(rng.uniform(0.05, 0.15, 20_000))           # irregular sampling
    prog = staircase(hold=(t[-1] - t[0]) / 7, start=t[0])
    signal = 1e-4 * model.response(t, prog.sample(t)) + 2e-9 * rng.standard_normal(len(t))
    c = compare.compare_record(net, t, signal)
    assert c.spice is not None and len(c.spice.time) > len(t)
    assert c.agreement_max_abs < 2e-6
    assert c.residual() is None and c.to_dict()["residual_creep_peak"] is None


def test_a_record_drives_ngspice_up_to_its_last_sample():
    # the netlist's stop time (12 digits) can lie a rounding past the last sample, where the
    # filesource has no next line and gives 0 V over the whole last interval: the record's
    # last sample is held one interval further, so ngspice sees the signal up to the end
    net = Network((Cell(1e6, 1e-5),), 3e7)
    t = np.arange(300) * 0.25
    t[-1] -= 5e-12
    signal = 1e-4 * (1.0 + 0.1 * np.sin(t / 5.0))
    c = compare.compare_record(net, t, signal)
    assert c.spice.time[-1] == pytest.approx(t[-1])
    np.testing.assert_allclose(c.spice.sensor, np.interp(c.spice.time, t, signal), rtol=0, atol=1e-13)
    assert np.max(np.abs(c.spice.output - c.reference.output)) < 1e-6 * 1e-4


def test_run_batch_reuses_one_engine_for_many_networks(default):
    model, nets = default
    exact = nets["exact"]
    impedance_x2 = exact.with_parts([v * 2 if k == "R" else v / 2 for _, k, v in exact.parts()])
    r1_high = exact.with_parts([v * 1.05 if label == "R1" else v for label, _, v in exact.parts()])
    networks = [exact, impedance_x2, r1_high]
    prog = drive.synthetic_program(model, "step")
    times = drive.transient_times(drive.spice_program(prog, model, exact), 900.0, 300)
    engine = ngspice_engine.ngspice()
    runs = ngspice_engine.run_batch(networks, model, prog, times, engine=engine)
    assert ngspice_engine.ngspice() is engine and len(runs) == 3
    for net, run in zip(networks, runs):
        ref = compare.reference_transient(net, model, prog, times)
        assert np.max(np.abs(run.output - ref.output)) / 1e-4 < 1e-6
    # twice the impedance level is the same H(s); a 5 % error in R1 is not
    np.testing.assert_allclose(runs[1].output, runs[0].output, atol=1e-6 * 1e-4)
    assert np.max(np.abs(runs[2].output - runs[0].output)) > 1e-3 * 1e-4


def test_a_broken_netlist_is_one_error_and_the_engine_recovers(default):
    model, nets = default
    engine = ngspice_engine.ngspice()
    with pytest.raises(ngspice_engine.NgspiceError, match="ngspice failed"):
        engine.run("broken\nR1 a 0 1k\nXbogus a 0 nosuchsubckt\n.tran 1 10\n.end\n")
    c = compare.compare_program(nets["paper"], model, "step", points=200)
    assert c.agreement_max_abs < 1e-6


def test_notes_are_notes_and_errors_are_errors():
    notes = ngspice_engine._check(
        "Circuit: x\nNote: No compatibility mode selected!",
        "Warning: voltage source vp has non-increasing PWL time points.\n"
        "Note: can't find init file.\nUsing SPARSE 1.3 as Direct Linear Solver", "x")
    assert len(notes) == 3
    with pytest.raises(ngspice_engine.NgspiceError, match="Timestep too small"):
        ngspice_engine._check("", "doAnalyses: TRAN:  Timestep too small; time = 1e-08", "the run")
    with pytest.raises(ngspice_engine.NgspiceError, match="Error on line 3"):
        ngspice_engine._check("Error on line 3 or its substitute:", "", "loading")


def test_without_ngspice_the_python_control_result_stands(default, monkeypatch):
    model, nets = default

    def missing():
        raise ngspice_engine.NgspiceUnavailable("ngspice is not installed; install it with: "
                                                f"{ngspice_engine.INSTALL_HINT}")

    monkeypatch.setattr(ngspice_engine, "_ENGINE", None)
    monkeypatch.setattr(ngspice_engine, "_load_shared", missing)
    c = compare.compare_program(nets["paper"], model, "step")
    assert c.spice is None and "apt-get install ngspice" in c.unavailable
    assert c.agreement_max_abs is None
    assert c.residual_creep_final == pytest.approx(PAPER_FINAL, rel=1e-6)
    d = c.to_dict()
    assert d["ngspice"]["available"] is False and d["agreement_max_abs"] is None
    r = compare.compare_record(nets["paper"], np.arange(100.0), np.arange(100.0) ** 0.5)
    assert r.spice is None and len(r.reference.output) == 100


def test_library_is_found_by_its_soname(monkeypatch):
    monkeypatch.delenv("NGSPICE_LIBRARY_PATH", raising=False)
    monkeypatch.setattr(ngspice_engine.ctypes.util, "find_library", lambda name: None)
    with pytest.raises(ngspice_engine.NgspiceUnavailable, match="apt-get install ngspice"):
        ngspice_engine._load_shared()


# --- reference netlists ----------------------------------------------------------------------

def test_reference_netlists_are_current(tmp_path):
    netlist.write_reference_netlists(tmp_path)
    fresh = {p.name: p.read_text() for p in tmp_path.iterdir()}
    committed = {p.name: p.read_text() for p in (REPO / "netlists").iterdir()
                 if p.suffix in (".cir", ".json")}
    assert set(fresh) == set(committed), "netlists/ differs: run make netlists"
    stale = [name for name in fresh if fresh[name] != committed[name]]
    assert stale == [], f"stale {stale}: run make netlists"
    assert all(str(tmp_path) not in text for text in fresh.values())


def _ngspice_batch(path: Path, cwd: Path):
    result = subprocess.run(["ngspice", "-b", path.name], cwd=cwd, capture_output=True,
                            text=True, timeout=120)
    measured = {m.group(1): float(m.group(2)) for m in
                re.finditer(r"^(\w+)\s*=\s*([-+0-9.eE]+)", result.stdout, re.MULTILINE)}
    return result, measured


@pytest.mark.parametrize("stem", list(netlist.reference_designs()))
def test_each_reference_netlist_runs_clean_in_ngspice_batch(stem, tmp_path):
    src = REPO / "netlists" / f"{stem}.cir"
    shutil.copy(src, tmp_path / src.name)
    result, measured = _ngspice_batch(src, tmp_path)
    assert result.returncode == 0, result.stderr
    assert ngspice_engine._check(result.stdout, result.stderr, "ngspice -b") is not None
    assert sorted(p.name for p in tmp_path.iterdir()) == [src.name]       # writes nothing
    design, _ = netlist.reference_designs()[stem]
    c = compare.compare_program(design.network, design.model, "step")
    assert measured["residual_creep_peak"] == pytest.approx(c.residual_creep_peak, rel=1e-4, abs=1e-9)
    assert measured["residual_creep_final"] == pytest.approx(c.residual_creep_final, rel=1e-4, abs=1e-9)
    assert measured["uncorrected_creep_final"] == pytest.approx(design.model.beta0, rel=1e-6)
    if stem == "default-paper":
        assert measured["residual_creep_final"] == pytest.approx(PAPER_FINAL, rel=1e-5)
