import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from creepcomp.errors import InputError
from creepcomp.model import CreepModel
from creepcomp.programs import LoadProgram, staircase, step, triangle_sweep


def test_step_between_samples_is_exact():
    m = CreepModel.voigt(0.03, 45.0)
    p = step(2.0, at=10.3)
    t = np.arange(0, 300.0, 1.0)
    expected = np.where(t >= 10.3, 2.0 * (1 + 0.03 * -np.expm1(-(t - 10.3) / 45.0)), 0.0)
    np.testing.assert_allclose(p.response(m.lag_expansion(), t), expected, atol=1e-14)


@given(st.integers(0, 2**31))
def test_response_does_not_depend_on_the_sample_grid(seed):
    rng = np.random.default_rng(seed)
    m = CreepModel(tuple(rng.uniform(0.005, 0.03, 2)), tuple(rng.uniform(2, 80, 2)))
    p = staircase(levels=tuple(rng.uniform(-1, 1, 4)), hold=float(rng.uniform(20, 120)))
    coarse = np.sort(rng.uniform(0, p.end, 50))
    fine = np.union1d(coarse, np.linspace(0, p.end, 3000))
    a = p.response(m.lag_expansion(), coarse)
    b = p.response(m.lag_expansion(), fine)[np.searchsorted(fine, coarse)]
    np.testing.assert_allclose(a, b, atol=1e-12)


def test_sweep_shapes_and_sampling():
    s = triangle_sweep(100.0, cycles=2, full_scale=3.0)
    np.testing.assert_allclose(s.sample([0, 25, 50, 75, 100, 112.5]), [0, 3, 0, -3, 0, 1.5])
    st_ = staircase((1, 2, 1, 0), hold=10)
    np.testing.assert_allclose(st_.sample([0, 5, 10, 15, 25, 35, 45]), [1, 1, 2, 2, 1, 0, 0])
    np.testing.assert_allclose(st_.sample_before([0, 10, 20]), [0, 1, 2])


@pytest.mark.parametrize("times,loads", [((0, 1), (0,)), ((1, 0), (0, 1)), ((0, 0, 0), (0, 1, 2)),
                                         ((0, float("nan")), (0, 1))])
def test_bad_programs(times, loads):
    with pytest.raises(InputError):
        LoadProgram(times, loads)
