import math

import control
import numpy as np
import pytest

from creepcomp.errors import InputError
from creepcomp.model import CreepModel


def test_transfer_function_is_one_plus_prony_terms():
    m = CreepModel((0.01, 0.01, 0.015), (5.0, 50.0, 500.0))
    w = np.logspace(-5, 1, 40)
    expected = 1 + sum(b / (1 + 1j * w * t) for b, t in zip(m.beta, m.tau))
    np.testing.assert_allclose(m.transfer_function()(1j * w), expected, rtol=1e-12)
    assert control.dcgain(m.transfer_function()) == pytest.approx(1.035)
    assert m.beta0 == pytest.approx(0.035)


def test_step_response_is_the_voigt_curve():
    m = CreepModel.voigt(0.03, 45.0)
    t = np.array([0.0, 10.0, 45.0, 300.0])
    load = np.ones_like(t)
    np.testing.assert_allclose(m.response(t, load), 1 + 0.03 * -np.expm1(-t / 45.0), atol=1e-15)


def test_settled_start_stays_put_and_gain_offset_apply():
    m = CreepModel((0.03, -0.01), (45.0, 4.0), gain=2.0, offset=0.5)
    t = np.linspace(0, 100, 11)
    y = m.response(t, np.full_like(t, 3.0), initial="settled")
    np.testing.assert_allclose(y, 0.5 + 2.0 * 3.0 * 1.02, atol=1e-14)


def test_unloading_recovers_by_superposition():
    m = CreepModel.voigt(0.05, 10.0)
    t = np.arange(0, 200.0, 0.5)
    load = (t < 100).astype(float)
    y = m.response(t, load, hold="zero")
    after = t >= 100
    creep_at_unload = 0.05 * -np.expm1(-100 / 10.0)
    np.testing.assert_allclose(y[after], creep_at_unload * np.exp(-(t[after] - 100) / 10.0), atol=1e-14)


@pytest.mark.parametrize("beta,tau,match", [
    ((0.0,), (45.0,), "beta0 = 0"),
    ((math.nan,), (45.0,), "beta0"),
    ((0.03,), (0.0,), "tau = 0"),
    ((0.03,), (-1.0,), "tau = -1"),
    ((0.03, 0.01), (45.0,), "one of each"),
    ((-1.2,), (45.0,), "greater than -1"),
    ((0.01, 0.0), (1.0, 2.0), r"beta\[1\] = 0"),
])
def test_invalid_models_say_what(beta, tau, match):
    with pytest.raises(InputError, match=match):
        CreepModel(beta, tau)


def test_from_dict_names_the_file():
    with pytest.raises(InputError, match="mymodel.*missing 'tau'"):
        CreepModel.from_dict({"beta": [0.03]}, where="mymodel")
    m = CreepModel.from_dict({"beta": [0.03], "tau": [45], "gain": 2, "extensions": {"x": 1}})
    assert m.to_dict()["extensions"] == {"x": 1} and m.gain == 2.0
