import numpy as np
import pytest
from hypothesis import given, strategies as st

from creepcomp.digital.correctors import (Corrector, _affine_recursion, _UniformBlocks,
    compensate, creep_error, default_initial, reference, saturation_factor, uniform_interval)
from creepcomp.errors import InputError
from creepcomp.lti import lag_coefficients
from creepcomp.model import CreepModel

THREE = CreepModel((0.006, 0.015, 0.009), (6.0, 45.0, 150.0), gain=2.5, offset=-0.4)


def held_loads(n, rng, hold=40):
    """A random staircase, new level every ``hold`` samples."""
    return np.repeat(rng.uniform(-1.0, 1.0, -(-n // hold)), hold)[:n]


def worst(a, b, scale):
    return float(np.max(np.abs(np.asarray(a) - np.asarray(b)))) / scale


# ---------------------------------------------------------------- exactness (uniform)

@pytest.mark.parametrize("dt", [1e-3, 0.05, 1.0, 200.0])
@pytest.mark.parametrize("hold", ["zero", "linear"])
def test_uniform_records_give_back_the_load_exactly(dt, hold):
    rng = np.random.default_rng(1)
    t = 17.0 + np.arange(20_000) * dt
    load = held_loads(len(t), rng)
    raw = THREE.response(t, load, hold=hold)
    fs = THREE.gain * np.max(np.abs(load))
    assert worst(raw, THREE.offset + THREE.gain * load, fs) > 1e-4 or dt < 0.01   # there is creep
    sub = compensate(t, raw, THREE, "subtractive", hold=hold)
    sup = compensate(t, raw, THREE, "supplemental", initial="relaxed", hold=hold)
    assert worst(sub, THREE.offset + THREE.gain * load, fs) < 1e-12
    assert worst(sup, THREE.offset + THREE.gain * (1 + THREE.beta0) * load, fs) < 1e-12


def test_creep_record_error_falls_from_3_percent_to_rounding():
    model = CreepModel.voigt(0.03, 45.0)
    t = np.arange(0, 900.0, 0.1)
    load = np.where(t >= 10.0, 1.0, 0.0)
    raw = model.response(t, load, hold="zero")
    before = creep_error(t, raw, load, model)
    after = creep_error(t, compensate(t, raw, model), load, model)
    assert before.peak_fraction == pytest.approx(0.03 * -np.expm1(-890 / 45), rel=1e-9)
    assert after.peak_fraction < 1e-12


def test_a_fast_direct_form_would_not_be_exact_but_the_block_engine_is():
    """Why not lfilter with the polynomial coefficients of 1/G(z): at dt/tau ~ 1e-4 its
    poles (all near z = 1) are moved by the coefficient rounding."""
    from scipy import signal

    model = THREE
    dt = 1e-3
    beta, taus = np.array(model.beta), np.array(model.tau)
    e, b0, _ = lag_coefficients(dt, taus, "zero")
    den = np.array([1.0])
    for ek in e:
        den = np.polymul(den, [1.0, -ek])
    num = den.copy()
    for k in range(3):
        part = np.array([0.0, beta[k] * b0[k]])
        for j in range(3):
            if j != k:
                part = np.polymul(part, [1.0, -e[j]])
        num = np.polyadd(num, part)
    t = np.arange(200_000) * dt
    load = np.where(t > 1.0, 1.0, 0.0)
    raw = model.lag_expansion().simulate(t, load, hold="zero")   # offset 0, gain 1
    direct = signal.lfilter(den, num, raw)
    assert np.max(np.abs(direct - load)) > 1e-6
    exact = compensate(t, raw, CreepModel(model.beta, model.tau))
    assert np.max(np.abs(exact - load)) < 1e-12


# ---------------------------------------------------------------- irregular sampling

models = st.lists(
    st.tuples(st.floats(0.002, 0.08) | st.floats(-0.08, -0.002), st.floats(0.5, 500.0)),
    min_size=1, max_size=4).filter(lambda terms: sum(b for b, _ in terms) > -0.5)


def model_of(terms, gain=1.7, offset=0.3):
    beta, tau = zip(*terms)
    return CreepModel(beta, tau, gain, offset)


@given(terms=models, seed=st.integers(0, 2 ** 32 - 1), hold=st.sampled_from(["zero", "linear"]),
       initial=st.sampled_from(["relaxed", "settled"]), uniform=st.booleans())
def test_any_sampling_is_exact(terms, seed, hold, initial, uniform):
    """Irregular steps from 1 ms to 50 min, or uniform ones; either sign of creep, 1-4 terms."""
    model = model_of(terms)
    rng = np.random.default_rng(seed)
    n = int(rng.integers(2, 600))
    if uniform:
        t = rng.uniform(-100, 100) + np.arange(n) * np.exp(rng.uniform(np.log(1e-3), np.log(3e3)))
    else:
        steps = np.exp(rng.uniform(np.log(1e-3), np.log(3e3), n - 1))
        t = rng.uniform(-100, 100) + np.concatenate([[0.0], np.cumsum(steps)])
    load = held_loads(len(t), rng, hold=int(rng.integers(1, 30)))
    raw = model.response(t, load, hold=hold, initial=initial)
    fs = abs(model.gain) * max(np.max(np.abs(load)), 1e-300)
    for method in ("subtractive", "supplemental"):
        y = compensate(t, raw, model, method, initial=initial, hold=hold)
        assert worst(y, reference(load, model, method), fs) < 1e-12


def test_the_long_run_stays_exact_where_the_paper_form_overflows():
    """t / tau = 10^6: uniform (10^6 samples) and irregular (bursts and long gaps)."""
    model = CreepModel((0.01, 0.012, 0.008), (20.0, 45.0, 100.0), gain=1.0, offset=0.0)
    rng = np.random.default_rng(5)
    t = np.arange(1_000_000) * 20.0                   # 231 days at one sample per tau_min
    assert t[-1] / 20.0 > 9.9e5
    load = held_loads(len(t), rng, hold=50)
    raw = model.response(t, load, hold="zero")
    for method in ("subtractive", "supplemental"):
        y = compensate(t, raw, model, method, initial="relaxed")
        assert worst(y, reference(load, model, method), 1.0) < 1e-12
    gaps = np.where(rng.random(20_000) < 0.01, rng.uniform(1e4, 1e6, 20_000), rng.uniform(0.01, 1, 20_000))
    t = np.cumsum(gaps)
    assert t[-1] / 20.0 > 1e5
    load = held_loads(len(t), rng, hold=30)
    raw = model.response(t, load, hold="zero")
    assert worst(compensate(t, raw, model), load, 1.0) < 1e-12


# ---------------------------------------------------------------- streaming

@given(terms=models, seed=st.integers(0, 2 ** 32 - 1), uniform=st.booleans(),
       hold=st.sampled_from(["zero", "linear"]), method=st.sampled_from(["subtractive", "supplemental"]),
       initial=st.sampled_from(["relaxed", "settled"]))
def test_streaming_in_random_chunks_equals_batch(terms, seed, uniform, hold, method, initial):
    model = model_of(terms)
    rng = np.random.default_rng(seed)
    n = int(rng.integers(1, 3000))
    dt = float(rng.uniform(0.01, 5.0))
    t = 3.0 + (np.arange(n) * dt if uniform else np.cumsum(rng.uniform(0.1, 2.0, n) * dt))
    raw = model.offset + model.gain * (held_loads(n, rng, 25) + 0.01 * rng.standard_normal(n))
    batch = compensate(t, raw, model, method, initial=initial, hold=hold)
    corrector = Corrector(model, method, dt=dt if uniform and n > 1 else None, initial=initial, hold=hold)
    cuts = np.sort(rng.integers(0, n + 1, int(rng.integers(0, 12))))
    pieces = []
    for a, b in zip(np.concatenate([[0], cuts]), np.concatenate([cuts, [n]])):
        if corrector.dt is not None:
            pieces.append(corrector.process(raw[a:b]))
        else:
            pieces.append(corrector.process(raw[a:b], t[a:b]))
    streamed = np.concatenate(pieces)
    scale = np.max(np.abs(raw - model.offset)) + 1e-300
    assert streamed.shape == batch.shape
    assert worst(streamed, batch, scale) < 1e-12


def test_streaming_one_sample_at_a_time_like_firmware():
    rng = np.random.default_rng(2)
    t = np.arange(3000) * 0.1
    load = held_loads(len(t), rng)
    raw = THREE.response(t, load, hold="zero")
    corrector = Corrector(THREE, "subtractive", dt=0.1)
    out = np.array([corrector.process([v])[0] for v in raw])
    assert worst(out, THREE.offset + THREE.gain * load, THREE.gain) < 1e-12
    assert corrector.creep_states.shape == (3,)


def test_block_engine_equals_the_per_sample_recursion_and_passes_are_seamless(monkeypatch):
    import creepcomp.digital.correctors as digital

    rng = np.random.default_rng(3)
    t = np.arange(10_007) * 0.3
    raw = THREE.offset + THREE.gain * held_loads(len(t), rng)
    uniform = Corrector(THREE, "subtractive", dt=0.3).process(raw)
    per_sample = Corrector(THREE, "subtractive").process(raw, t)     # irregular engine
    assert worst(uniform, per_sample, THREE.gain) < 1e-12
    monkeypatch.setattr(digital, "PASS_SAMPLES", 37)
    assert worst(Corrector(THREE, "subtractive", dt=0.3).process(raw), uniform, THREE.gain) < 1e-12


def test_block_matrices_come_from_the_lti_coefficients():
    beta, taus = np.array(THREE.beta), np.array(THREE.tau)
    blocks = _UniformBlocks.build(beta, taus, 0.5, "linear")
    e, b0, b1 = lag_coefficients(0.5, taus, "linear")
    np.testing.assert_allclose(blocks.e, e, rtol=0, atol=0)
    D = 1 + beta @ b1
    np.testing.assert_allclose(blocks.M, np.diag(e) - np.outer((e * b1 + b0) / D, beta), atol=1e-15)
    # output matrix = impulse response of the per-sample recursion
    x = np.zeros(16)
    x[0] = 1.0
    q = _affine_recursion(np.outer(x[:-1], (e * b1 + b0) / D), np.zeros(3), M=blocks.M)
    np.testing.assert_allclose(blocks.output[:, 0], x / D - q @ beta / D, atol=1e-15)


def test_affine_recursion_matches_a_plain_loop():
    rng = np.random.default_rng(4)
    u = rng.standard_normal((50, 3))
    q0 = rng.standard_normal(3)
    M = rng.uniform(-0.4, 0.4, (3, 3))
    diagonal, feedback = rng.uniform(0, 1, (50, 3)), rng.uniform(0, 1, (50, 3))
    beta = rng.uniform(-1, 1, 3)
    constant, varying = [q0], [q0]
    for i in range(50):
        constant.append(M @ constant[-1] + u[i])
        varying.append((np.diag(diagonal[i]) - np.outer(feedback[i], beta)) @ varying[-1] + u[i])
    np.testing.assert_allclose(_affine_recursion(u, q0, M=M), constant, rtol=1e-13, atol=1e-13)
    np.testing.assert_allclose(_affine_recursion(u, q0, diagonal=diagonal, feedback=feedback, beta=beta),
                               varying, rtol=1e-13, atol=1e-13)


# ---------------------------------------------------------------- starts, signs, terms

def test_settled_start_is_exact_and_relaxed_start_is_not_for_a_record_that_starts_loaded():
    t = np.arange(0, 600.0, 0.5)
    load = np.where(t < 300, 0.8, -0.2)
    raw = THREE.response(t, load, hold="zero", initial="settled")
    for method in ("subtractive", "supplemental"):
        ref = reference(load, THREE, method)
        settled = compensate(t, raw, THREE, method, initial="settled")
        relaxed = compensate(t, raw, THREE, method, initial="relaxed")
        assert worst(settled, ref, THREE.gain) < 1e-12
        assert worst(relaxed, ref, THREE.gain) > 1e-3


def test_explicit_initial_states():
    t = np.arange(0, 100.0, 0.25)
    load = np.full(len(t), 0.5)
    c0 = [0.1, 0.3, 0.2]
    raw = THREE.response(t, load, hold="zero", initial=c0)
    y = compensate(t, raw, THREE, initial=[THREE.gain * c for c in c0])   # states in signal units
    assert worst(y, THREE.offset + THREE.gain * load, THREE.gain) < 1e-12


def test_negative_creep_and_many_terms():
    rng = np.random.default_rng(6)
    overshoot = CreepModel((-0.02, -0.015), (3.0, 80.0), gain=-1.5, offset=2.0)
    five = CreepModel((0.004, 0.008, 0.01, 0.006, 0.002), (1.0, 7.0, 30.0, 120.0, 900.0))
    for model in (overshoot, five):
        t = np.cumsum(rng.uniform(0.05, 0.5, 8000))
        load = held_loads(len(t), rng, 200)
        raw = model.response(t, load, hold="zero")
        assert worst(compensate(t, raw, model), reference(load, model), abs(model.gain)) < 1e-12
        assert worst(compensate(t, raw, model, "supplemental", initial="relaxed"),
                     reference(load, model, "supplemental"), abs(model.gain)) < 1e-12


def test_supplemental_is_the_saturated_scale_of_subtractive():
    rng = np.random.default_rng(7)
    t = np.arange(5000) * 0.2
    raw = THREE.offset + rng.standard_normal(5000)
    sub = compensate(t, raw, THREE, "subtractive", initial="settled")
    sup = compensate(t, raw, THREE, "supplemental", initial="settled")
    np.testing.assert_allclose(sup - THREE.offset, (1 + THREE.beta0) * (sub - THREE.offset),
                               rtol=1e-12, atol=1e-12)
    assert saturation_factor(THREE, "supplemental") == pytest.approx(1.03)
    assert default_initial("subtractive") == "relaxed" and default_initial("supplemental") == "settled"


def test_saturated_signal_is_left_alone_by_supplemental_from_a_settled_start():
    t = np.arange(0, 50.0, 0.1)
    raw = np.full(len(t), THREE.offset + THREE.gain * 1.03 * 0.7)
    np.testing.assert_allclose(compensate(t, raw, THREE, "supplemental"), raw, rtol=0, atol=1e-14)


# ---------------------------------------------------------------- error measure, helpers

def test_creep_error_against_the_reference():
    t = np.arange(5.0)
    load = np.array([0.0, 1.0, 2.0, -4.0, 0.0])
    ref = reference(load, THREE, "supplemental")
    np.testing.assert_allclose(ref, THREE.offset + THREE.gain * 1.03 * load)
    err = creep_error(t, ref + np.array([0, 0.1, -0.2, 0, 0]), load, THREE, "supplemental")
    assert err.peak == pytest.approx(0.2) and err.peak_time == 2.0
    assert err.rms == pytest.approx(np.sqrt(0.05 / 5))
    assert err.full_scale == pytest.approx(THREE.gain * 1.03 * 4)
    assert err.peak_fraction == pytest.approx(0.2 / err.full_scale)
    none = creep_error(t, np.full(5, THREE.offset), np.zeros(5), THREE)
    assert none.peak == 0 and none.peak_fraction is None
    assert set(err.to_dict()) == {"rms", "peak", "peak_time", "rms_fraction", "peak_fraction", "full_scale"}


def test_uniform_interval_allows_the_rounding_of_long_decimal_times_only():
    t = np.arange(10_000_000) * 0.01                     # steps vary by rounding: ~1e-9 relative
    assert uniform_interval(t) == pytest.approx(0.01, rel=1e-12)
    jitter = t[:1000] + np.random.default_rng(0).uniform(0, 1e-6, 1000)
    assert uniform_interval(jitter) is None
    assert uniform_interval([1.0]) is None


# ---------------------------------------------------------------- bad input

def test_bad_input_is_refused_with_a_clear_message():
    t = np.arange(10.0)
    raw = np.zeros(10)
    with pytest.raises(InputError, match="method 'additive'"):
        compensate(t, raw, THREE, "additive")
    with pytest.raises(InputError, match="hold 'cubic'"):
        compensate(t, raw, THREE, hold="cubic")
    with pytest.raises(InputError, match="initial state 'warm'"):
        compensate(t, raw, THREE, initial="warm")
    with pytest.raises(InputError, match="strictly increasing"):
        compensate(t[::-1], raw, THREE)
    with pytest.raises(InputError, match="not a finite number"):
        compensate(t, np.where(t == 4, np.nan, 0.0), THREE)
    with pytest.raises(InputError, match="equal length"):
        compensate(t, raw[:5], THREE)
    with pytest.raises(InputError, match="expected 3 finite values"):
        compensate(t, raw, THREE, initial=[0.0, 1.0])
    with pytest.raises(InputError, match="not in the left half-plane"):
        Corrector(CreepModel((-1.5, 1.0), (1.0, 100.0)))


def test_corrector_chunks_must_come_with_or_without_times_as_set_up():
    with pytest.raises(InputError, match="give the sample times"):
        Corrector(THREE).process([1.0, 2.0])
    with pytest.raises(InputError, match="fixed sampling interval"):
        Corrector(THREE, dt=0.1).process([1.0], [0.0])
    with pytest.raises(InputError, match="sampling interval must be positive"):
        Corrector(THREE, dt=0.0)
    irregular = Corrector(THREE)
    irregular.process([0.0, 0.1], [0.0, 1.0])
    with pytest.raises(InputError, match="0.5 s follows 1 s"):
        irregular.process([0.2], [0.5])
    assert Corrector(THREE, dt=1.0).process([]).shape == (0,)
