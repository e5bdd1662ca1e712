"""The refinement's Jacobian of a model with an effect (variable projection, the basis's
derivatives analytic through the lag recursion or by differences of the basis alone) against
central differences of the projected residual, per effect, on a small record."""

import numpy as np
import pytest

from creepcomp import synth
from creepcomp.diagnose import effects
from creepcomp.fit.data import prepare
from creepcomp.fit.solver import Problem, fit_structure
from creepcomp.fit.structure import Structure, basis_derivatives
from creepcomp.synth.sensor import EFFECTS, random_spec


def _problem(name: str, seed: int = 3):
    """The problem of ``name`` on a base fit of a 10-minute 2 Hz record hiding it, and a search
    point (the base's values, the effect's first start) inside the bounds."""
    record = synth.generate(random_spec(name, seed, rate=(2.0, 2.0), duration=(600.0, 600.0))).record
    data = prepare(record, initial="free")
    base = fit_structure(data, Structure(1), [{"tau[0]": 50.0}], with_cov=False)
    effect = effects.get(name)
    applied, structure = effect._on(data, base, None)
    start = {p.name: base.values[p.name] for p in base.params}
    if name == "extra_retardation":
        start.update({"tau[1]": 7.0, "c0[1]": 0.0})
    else:
        own = effect.starts(data, base, applied)[0]
        start.update({effect._key(applied, k): v for k, v in own.items()})
    problem = Problem(data, structure)
    x = problem.start_vector(start)
    # a parameter at its bound (a Newtonian exponent, a plain decay) has one-sided derivatives
    for j, p in enumerate(problem.params):
        lo, hi = p.bounds()
        x[j] = min(max(x[j], lo + 0.2 * (hi - lo)), hi - 0.2 * (hi - lo)) if np.isfinite(hi - lo) else x[j]
    return problem, x


@pytest.mark.parametrize("name", EFFECTS)
def test_jacobian_with_an_effect_matches_central_differences(name):
    problem, x = _problem(name)
    jac = problem.jacobian(x)
    step = 1e-6 * np.maximum(1.0, np.abs(x))
    fd = np.column_stack([(problem.residual(x + h * e) - problem.residual(x - h * e)) / (2 * h)
                          for h, e in zip(step, np.eye(len(x)))])
    scale = np.max(np.abs(fd), axis=0)
    # per parameter, relative to its own derivative; a parameter the linear part absorbs
    # (derivative at the rounding of the differences) against the largest
    assert np.all(np.max(np.abs(jac - fd), axis=0) <= 1e-3 * scale + 1e-6 * scale.max()), name


def test_lag_parameters_of_a_plain_lag_model_are_analytic():
    """With effects that leave the lags alone, time constants and initial states move their
    lag columns by the recursion's derivatives (no evaluation of the basis), exactly as the
    plain Prony model's; an extra term is one of them."""
    problem, x = _problem("extra_retardation")
    values = problem.values(x)
    b = problem.basis(x)
    plain = Structure(problem.structure.n_terms)
    lag_params = [p for p in problem.params if p.name.startswith(("tau[", "c0["))]
    with_effect = basis_derivatives(problem.data, problem.structure, values, b, lag_params,
                                    with_effects=True)
    alone = basis_derivatives(problem.data, plain, values, b, lag_params)
    assert basis_derivatives(problem.data, problem.structure, values, b, lag_params) is None
    for m1, m2 in zip(with_effect, alone):
        assert [c for c, _ in m1] == [c for c, _ in m2]
        for (_, d1), (_, d2) in zip(m1, m2):
            np.testing.assert_array_equal(d1, d2)


@pytest.mark.parametrize("hold", ["linear", "zero"])
def test_varying_lag_derivatives_match_central_differences(hold):
    """The forward-mode recursion of lags whose time constants change step by step equals
    central differences of the lags along a direction of those time constants and of the
    initial state."""
    from creepcomp.lti import varying_lag_derivatives, varying_lag_states

    rng = np.random.default_rng(1)
    t = np.cumsum(rng.uniform(0.05, 0.3, 3000))
    u = np.repeat(rng.normal(size=30), 100)
    taus = np.column_stack([np.where(np.arange(2999) % 700 < 350, 2.0, 9.0), np.full(2999, 60.0)])
    slopes = np.column_stack([taus[:, 0] * (np.arange(2999) % 700 < 350), taus[:, 1]])
    c0 = np.array([0.3, -0.2])
    states = varying_lag_states(t, u, taus, hold=hold, initial=c0)
    out = varying_lag_derivatives(t, u, taus, states, slopes, hold, initial_slope=[0.5, 0.0])
    h = 1e-6
    fd = (varying_lag_states(t, u, taus + h * slopes, hold=hold, initial=c0 + h * np.array([0.5, 0.0]))
          - varying_lag_states(t, u, taus - h * slopes, hold=hold, initial=c0 - h * np.array([0.5, 0.0]))) / (2 * h)
    assert np.max(np.abs(out - fd)) <= 1e-6 * np.max(np.abs(fd))


def test_recovery_switched_by_the_load_direction_has_the_jacobian_of_its_differences():
    problem, x = _problem("asymmetric_recovery")
    effect = effects.get("asymmetric_recovery")
    applied = problem.structure.effects[-1]
    structure = Structure(problem.structure.n_terms,
                          (type(applied)(effect, applied.settings + (("switch", "direction"),)),))
    problem = Problem(problem.data, structure)
    jac = problem.jacobian(x)
    step = 1e-6 * np.maximum(1.0, np.abs(x))
    fd = np.column_stack([(problem.residual(x + h * e) - problem.residual(x - h * e)) / (2 * h)
                          for h, e in zip(step, np.eye(len(x)))])
    scale = np.max(np.abs(fd), axis=0)
    assert np.all(np.max(np.abs(jac - fd), axis=0) <= 1e-3 * scale + 1e-6 * scale.max())
