"""Sparse records: one term fitted on five samples and more, with a small-sample covariance;
fewer than five samples refused with the reason."""

import numpy as np
import pytest

from creepcomp.errors import InputError
from creepcomp.fit import fit_prony, prepare
from creepcomp.fit.noise import MAX_AR_ORDER, SPARSE_SAMPLES, is_sparse, rows_for
from creepcomp.fit.prony import term_table
from creepcomp.fit.solver import small_sample_inflation
from creepcomp.io.records import Record

BETA, TAU, GAIN = 0.3, 20.0, 2.0


def creep_test(n: int, seed: int, noise: float = 0.01, spacing=np.geomspace) -> Record:
    """A creep test (load step at t = 0) sampled at ``n`` times over 1-100 h (log-spaced) of
    a one-term creep, ``noise`` of the signal's level white."""
    t = spacing(1.0, 100.0, n)
    clean = GAIN * (1.0 + BETA * (1.0 - np.exp(-t / TAU)))
    rng = np.random.default_rng(seed)
    return Record(t, np.ones(n), clean + noise * GAIN * rng.normal(size=n), source=f"sparse-{n}")


@pytest.mark.parametrize("n", [5, 12])
def test_a_sparse_record_fits_one_term_with_a_wide_honest_interval(n):
    fits = [fit_prony(prepare(creep_test(n, seed), load_step_at=0.0)).fit for seed in range(12)]
    assert all(f.structure.n_terms == 1 and f.noise.order == 0 for f in fits)
    terms = [term_table(f)[0] for f in fits]
    errors = np.array([abs(t["beta"] - BETA) / t["beta_sigma"] for t in terms])
    # honest: about two thirds within one stated sigma (without the small-sample inflation
    # a third at five samples), most within two
    assert np.count_nonzero(errors < 1.0) >= 7 and np.count_nonzero(errors < 2.0) >= 10
    # wide: the t quantile and the unbiased variance inflate the linearised sigma
    k = fits[0].n_params - 1
    assert small_sample_inflation(n, k) > (3.0 if n == 5 else 1.3)
    assert np.median([t["beta_sigma"] for t in terms]) > 0.01 * BETA


def test_the_small_sample_inflation_is_the_t_quantile_on_the_unbiased_variance():
    assert small_sample_inflation(5, 4) == pytest.approx(5 / 1 * 1.8373 ** 2, rel=1e-3)
    assert small_sample_inflation(12, 3) == pytest.approx(12 / 9 * 1.0590 ** 2, rel=1e-3)
    assert small_sample_inflation(4, 4) == float("inf")


def test_five_samples_with_a_load_step_inside_fit_one_term_settled():
    """Offset free, initial state free: five samples carry one term only with the initial
    state settled (gain, offset, beta, tau and the noise)."""
    t = np.arange(5.0) * 10.0
    load = np.array([0.0, 1.0, 1.0, 1.0, 1.0])
    signal = 0.1 + GAIN * load * (1.0 + BETA * (1.0 - np.exp(-(t - 5.0).clip(0) / TAU)))
    signal = signal + 1e-3 * np.random.default_rng(0).normal(size=5)
    result = fit_prony(prepare(Record(t, load, signal, source="five")))
    assert result.data.initial == "settled" and result.fit.structure.n_terms == 1
    assert np.isfinite(result.fit.cov).all()
    assert "sparse record (5 samples, 1 degrees of freedom)" in result.to_dict()["uncertainty"]["note"]
    # held out: a fold's four samples refit the linear part (not all four parameters), so
    # the held-out residual is a prediction, not the in-sample residual again
    assert result.fit.heldout.rms > 1.5 * result.fit.residual_rms


def test_four_samples_are_refused_by_name_with_the_reason():
    with pytest.raises(InputError, match=r"sparse-4: 4 samples is too few for fitting a creep "
                                         r"model \(needs at least 5"):
        prepare(creep_test(4, 0), load_step_at=0.0)


def test_the_cli_refuses_four_samples_with_exit_2(run_cli, tmp_path):
    path = tmp_path / "four.csv"
    r = creep_test(4, 0)
    path.write_text("time,load,signal\n" + "".join(f"{a},{b},{c}\n" for a, b, c in
                                                   zip(r.time, r.load, r.signal)))
    status, out, err = run_cli("fit", path, "--load-step-at", "0")
    assert status == 2 and "4 samples is too few" in err and "Traceback" not in err


def test_records_of_the_old_minimum_keep_the_ar_noise_model_rows():
    def one_term(n):
        record = creep_test(n, 1, spacing=np.linspace)     # (evenly: no gaps)
        return fit_prony(prepare(record, load_step_at=0.0), n_terms=1).fit
    fit, sparse = one_term(SPARSE_SAMPLES), one_term(SPARSE_SAMPLES - 1)
    assert fit.n_rows == SPARSE_SAMPLES - 5          # five predecessors for the AR model
    assert sparse.n_rows == SPARSE_SAMPLES - 1       # white: every sample


def test_more_terms_than_a_sparse_record_carries_are_refused_with_the_count():
    data = prepare(creep_test(5, 0), load_step_at=0.0)
    with pytest.raises(InputError, match=r"5 samples cannot determine 2 terms \(5 parameters and "
                                         r"the noise need at least 6\)"):
        fit_prony(data, n_terms=2)


def _two_terms(n: int, seed: int) -> Record:
    """A creep test with two terms (20 % at 2 h, 30 % at 40 h), ``n`` log-spaced samples over
    0.5-100 h, 1.2 % white noise."""
    t = np.geomspace(0.5, 100.0, n)
    clean = GAIN * (1.0 + 0.2 * (1.0 - np.exp(-t / 2.0)) + 0.3 * (1.0 - np.exp(-t / 40.0)))
    noise = 0.012 * GAIN * np.random.default_rng(seed).normal(size=n)
    return Record(t, np.ones(n), clean + noise, source=f"two-terms-{n}")


def test_a_sparse_record_takes_the_second_term_its_samples_support():
    # (the strong rule, BIC lower by 10 and held-out blocks of one or two samples predicted
    # better, kept one term on 6 of these 20)
    terms = [fit_prony(prepare(_two_terms(n, seed), load_step_at=0.0)).fit.structure.n_terms
             for n in (12, 16) for seed in range(10)]
    assert terms.count(2) >= 18


def test_a_record_sampled_ever_more_sparsely_is_fitted_as_a_sparse_one():
    # 22 samples: eleven 36 s apart, then hours apart (as a creep test is often logged): a
    # gap at most later steps, too few samples with five predecessors for an AR noise model
    hours = np.concatenate([np.arange(11) * 0.01, [0.2, 1.2, 2.3, 3.8, 5.6, 24, 42, 60, 94, 118, 152]])
    t = hours * 3600.0
    clean = GAIN * (1.0 + BETA * (1.0 - np.exp(-hours / TAU)))
    record = Record(t, np.ones(len(t)), clean + 0.005 * GAIN * np.random.default_rng(3).normal(size=len(t)),
                    source="logged")
    data = prepare(record, load_step_at=0.0)
    assert len(rows_for(data, order=MAX_AR_ORDER)) < SPARSE_SAMPLES - MAX_AR_ORDER
    assert is_sparse(data)
    fit = fit_prony(data).fit
    assert fit.noise.order == 0 and fit.n_rows == len(t)
    assert term_table(fit)[-1]["tau"] == pytest.approx(TAU * 3600.0, rel=0.3)
