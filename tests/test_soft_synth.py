"""The soft-sensor generator's physics: transfers, creep, memory and the bench's faults."""

import numpy as np
import pytest

from creepcomp.errors import InputError
from creepcomp.synth.soft import (LOAD_CELL_CREEP_RANGE, SOFT_CREEP_RANGE, SOFT_KINDS, SOFT_PROGRAMS,
                                  soft_program, soft_record)

#: No creep, memory or set: the static transfer alone.
STATIC = dict(beta=(0.0,), tau=(1.0,), unloading_tau_factor=1.0, softening=0.0, permanent_set=0.0,
              output_creep=None, release_spike=None, climb=None, offset_jumps=(), clip=None)


def _held(s, fraction=0.5):
    """Samples held at a load of at least ``fraction`` of full scale, and those at rest."""
    x = s.true_load / s.parameters["full_scale"]
    return x >= fraction, x <= 1e-9


def test_an_fsr_reading_falls_over_decades_with_load():
    s = soft_record("fsr", 3, program="staircase", readout="ohmmeter", digits=5, noise=1e-4,
                    coloured_noise=0.0, input_power=1.0,
                    transfer={"form": "power_law", "r0": 1000.0, "exponent": 1.0, "strain_floor": 1e-3,
                              "series": 50.0, "parallel": 1e6}, **STATIC)
    loaded, rest = _held(s)
    ratio = np.median(s.record.signal[rest]) / np.median(s.record.signal[loaded])
    assert ratio > 100
    # the higher the load, the lower the resistance, level by level
    levels = np.unique(np.round(s.true_load[s.true_load > 0], 9))
    means = [np.median(s.record.signal[np.isclose(s.true_load, v)]) for v in levels]
    assert np.all(np.diff(means) < 0)


@pytest.mark.parametrize("seed", range(8))
def test_drawn_fsrs_span_more_than_a_decade(seed):
    s = soft_record("fsr", seed, max_samples=800)
    assert s.clean.max() / s.clean.min() > 10


def test_a_pad_saturates():
    s = soft_record("velostat", 5, program="staircase", readout="ohmmeter", noise=1e-4,
                    coloured_noise=0.0, input_power=1.0, **STATIC)
    x = s.true_load / s.parameters["full_scale"]
    y, unloaded = s.clean, s.clean[x == 0].max()
    # the loaded reading sits at a few percent of the unloaded one near full scale
    ratio = s.parameters["transfer"]["loaded_ratio"]
    near_full = x >= 0.9 * x.max()
    assert np.all(y[near_full] / unloaded < ratio + 0.25 * (1 - ratio))
    # saturating: the second half of the load moves the reading less than the first half
    order = np.argsort(x)
    y_of = lambda v: np.interp(v, x[order], y[order])
    top = x.max()
    assert abs(y_of(top) - y_of(top / 2)) < abs(y_of(top / 2) - y_of(0.0))


def test_release_overshoot_spikes_above_the_unloaded_level_and_decays():
    s = soft_record("velostat", 11, program="step", readout="ohmmeter", noise=1e-4, coloured_noise=0.0,
                    **{**STATIC, "release_spike": {"amplitude": 0.5, "tau": 1.0}})
    t, y = s.record.time, s.clean
    release = s.program.times[-2]          # the release ramp's end
    after = t >= release
    first = y[after][0]
    later = y[after & (t > release + 10.0)]
    assert first > 1.2 * later.mean()              # spikes up by a fraction of the overshoot
    assert abs(later[-1] - later.mean()) < 0.01 * later.mean()   # and has decayed after 10 s


@pytest.mark.parametrize("amplitude, overshoots", [(0.3, True), (-0.3, False)])
def test_output_creep_overshoots_or_approaches_by_its_sign(amplitude, overshoots):
    s = soft_record("carbon_stretch", 2, program="step", noise=1e-4, coloured_noise=0.0,
                    **{**STATIC, "output_creep": {"amplitude": amplitude, "tau": 5.0}})
    t, y = s.record.time, s.clean
    on, off = s.program.times[2], s.program.times[3]
    hold = (t >= on) & (t < off)
    settled = y[hold][-1]
    rest = y[t < s.program.times[1]].mean()
    step = settled - rest
    first = y[hold][0] - rest
    assert (first > 1.2 * step) if overshoots else (first < 0.8 * step)


def test_a_linear_converter_quantises_to_its_step():
    s = soft_record("load_cell", 4, bits=12, clip=None)
    p = s.parameters
    counts = (s.record.signal - p["converter_low"]) / p["lsb"]
    np.testing.assert_allclose(counts, np.round(counts), atol=1e-6)
    assert len(np.unique(np.round(counts))) > 50


def test_a_divider_is_read_in_counts_and_an_ohmmeter_to_its_digits():
    d = soft_record("fsr", 6, readout="divider", bits=10, clip=None)
    assert d.record.unit("signal") == "counts"
    np.testing.assert_array_equal(d.record.signal, np.round(d.record.signal))
    assert 0 <= d.record.signal.min() and d.record.signal.max() <= 1023
    o = soft_record("fsr", 6, readout="ohmmeter", digits=3, clip=None)
    y = o.record.signal
    mantissa = y / 10.0 ** (np.floor(np.log10(y)) - 2)
    np.testing.assert_allclose(mantissa, np.round(mantissa), atol=1e-6)


@pytest.mark.parametrize("side", ["high", "low"])
def test_clipping_at_the_converters_rails(side):
    s = soft_record("carbon_stretch", 8, clip={"side": side, "inside": 0.05}, noise=1e-3, coloured_noise=0.0)
    p, y = s.parameters, s.record.signal
    rail = p["converter_high"] if side == "high" else p["converter_low"]
    at_rail = np.isclose(y, rail, rtol=0, atol=1e-9 * max(abs(rail), 1.0))
    beyond = s.clean > rail if side == "high" else s.clean < rail
    assert beyond.any() and np.all(at_rail[beyond & (np.abs(s.clean - rail) > 0.02 * np.ptp(s.clean))])
    assert p["clipped_fraction"] == pytest.approx(at_rail.mean())
    assert (y <= rail + 1e-9 * abs(rail)).all() if side == "high" else (y >= rail - 1e-9 * abs(rail)).all()


def test_same_seed_same_record_other_seed_other_record():
    a, b, c = soft_record("velostat", 21), soft_record("velostat", 21), soft_record("velostat", 22)
    np.testing.assert_array_equal(a.record.signal, b.record.signal)
    np.testing.assert_array_equal(a.record.load, b.record.load)
    assert a.parameters == b.parameters
    assert a.parameters != c.parameters


@pytest.mark.parametrize("kind", SOFT_KINDS)
def test_drawn_creep_is_within_its_range_and_the_clock_rarely_starts_at_zero(kind):
    lo, hi = LOAD_CELL_CREEP_RANGE if kind == "load_cell" else SOFT_CREEP_RANGE
    starts = []
    for seed in range(12):
        s = soft_record(kind, seed, max_samples=300)
        assert lo - 1e-12 <= abs(s.parameters["creep_total"]) <= hi + 1e-12
        assert s.record.time[0] == s.parameters["start"]
        starts.append(s.parameters["start"])
    assert sum(t != 0 for t in starts) >= 6


def test_strain_creeps_by_the_drawn_fraction_under_a_held_load():
    s = soft_record("foam_taxel", 9, program="step", **{**STATIC, "beta": (0.3,), "tau": (5.0,)})
    t, e = s.record.time, s.strain
    on, off = s.program.times[2], s.program.times[3]
    instant = e[np.searchsorted(t, on)]
    settled = e[np.searchsorted(t, off) - 1]
    # the ramp lasts a fraction of a second: the strain has crept by at most 5 % of beta then
    assert settled / instant - 1 == pytest.approx(0.3, abs=0.02)


def test_first_cycle_leaves_a_permanent_set():
    s = soft_record("carbon_stretch", 12, program="step",
                    **{**STATIC, "permanent_set": 0.05, "softening": 0.1})
    e = s.strain
    # the largest strain before softening: the held level through the input map
    peak = (s.true_load.max() / s.parameters["full_scale"]) ** s.parameters["input_power"]
    assert e[0] == 0.0
    assert e[-1] == pytest.approx(0.05 * peak, rel=1e-6)
    # softer while held than the static map: stretched by 10 % of the peak, plus the set
    assert e.max() == pytest.approx(peak * (1 + 0.1 * peak) + 0.05 * peak, rel=1e-6)


def test_foam_counts_fall_with_pressure_with_noise_of_a_twentieth_of_the_range():
    s = soft_record("foam_taxel", 14)
    assert np.corrcoef(s.true_load, s.record.signal)[0, 1] < -0.5
    assert 0.03 <= s.parameters["noise"] <= 0.07
    assert s.record.unit("signal") == "counts"


def test_the_reference_load_has_noise_of_its_own():
    s = soft_record("load_cell", 15, reference_noise=0.003)
    spread = np.std(s.record.load - s.true_load) / np.ptp(s.true_load)
    assert spread == pytest.approx(0.003, rel=0.15)


@pytest.mark.parametrize("kind", SOFT_PROGRAMS)
def test_programs_start_at_rest_and_stay_within_full_scale(kind):
    p = soft_program(kind, 300.0, np.random.default_rng(5), 10.0, start=50.0)
    assert p.loads[0] == 0.0 and p.start == 50.0 and p.end == pytest.approx(350.0)
    assert 0.0 <= min(p.loads) and max(p.loads) <= 10.0 and max(p.loads) > 1.0


def test_unknown_kind_or_parameter_is_refused():
    with pytest.raises(InputError, match="sensor kind"):
        soft_record("strain_gauge", 1)
    with pytest.raises(InputError, match="no parameter named"):
        soft_record("fsr", 1, colour="red")
