"""Diagnosis of synthetic records with hidden effects: named, parameters recovered, gain.

Each effect is hidden in records with random parameters, sample rates (2-50 Hz), load
programs, durations, noise level and colour (see :func:`creepcomp.synth.sensor.random_spec`); the
records are kept small (at most 5000 samples) so that the suite stays fast. The wide
confusion matrix is ``benchmarks/diagnose_confusion.py``.
"""

import warnings

import numpy as np
import pytest

from creepcomp import synth
from creepcomp.diagnose.sensor import diagnose

SMALL = dict(max_samples=5000, duration=(600.0, 2400.0), noise=(2e-4, 1e-3))
# parameters the contract names, and the effects they belong to
CHECKED = {"extra_retardation": ("tau", "beta"), "viscous_flow": ("rate",),
           "asymmetric_recovery": ("tau_recovery",), "thermal_drift": ("coefficient",),
           "time_offset": ("delay",)}


def _check(effect, seed):
    syn = synth.random_record(effect, seed, **SMALL)
    d = diagnose(syn.record)
    assert d.cause == effect, (seed, d.cause, [t.to_dict() for t in d.trials])
    finding = d.findings[0]
    truth = synth.reported_truth(syn)[effect]
    for name in CHECKED.get(effect, ()):
        assert finding.parameters[name] == pytest.approx(truth[name], rel=0.2), (seed, name)
    assert d.gain["heldout_rms_ratio"] > 1.0
    return d


SLOW_EFFECTS = ("extra_retardation", "nonlinear_creep", "time_offset", "mullins_softening")


@pytest.mark.parametrize("effect", [pytest.param(e, marks=pytest.mark.slow) if e in SLOW_EFFECTS else e
                                    for e in synth.EFFECTS])
def test_hidden_effect_is_named_and_its_parameters_recovered(effect):
    _check(effect, seed=0)


@pytest.mark.parametrize("seed", [0, 255, 64286])
def test_clean_record_is_none(seed):
    syn = synth.random_record(None, seed, **SMALL)
    d = diagnose(syn.record)
    assert d.cause == "none", [t.to_dict() for t in d.trials]
    assert d.findings == ()
    assert d.gain["heldout_rms_ratio"] == pytest.approx(1.0)


def test_json_follows_the_contract():
    syn = synth.generate(synth.Spec(hidden={"viscous_flow": {"rate": 4e-5}}, duration=1200, rate=4,
                                    program="staircase", seed=2))
    out = diagnose(syn.record).to_dict()
    assert out["cause"] == "viscous_flow"
    f = out["findings"][0]
    assert f["effect"] == "viscous_flow" and "rate" in f["parameters"]
    assert {"delta_bic", "heldout_rms_ratio"} <= set(f["evidence"])
    for key in ("baseline", "extended"):
        assert {"residual_rms", "heldout_residual_rms"} <= set(out[key])
    assert out["extended"]["heldout_residual_rms"] < out["baseline"]["heldout_residual_rms"]
    assert out["gain"]["heldout_rms_ratio"] == pytest.approx(
        out["baseline"]["heldout_residual_rms"] / out["extended"]["heldout_residual_rms"])
    assert out["gain"]["correction_error_ratio"] > 1.0
    assert out["extended_model"]["extensions"]["viscous_flow"]["rate"] == pytest.approx(4e-5, rel=0.1)


@pytest.mark.slow
def test_two_effects_added_one_at_a_time():
    # (sizes within the generator's ranges: a drift 4x larger drags the one-term baseline
    # to a slow negative term that hides both; see docs/benchmarks.md, known limitations)
    syn = synth.generate(synth.Spec(hidden={"thermal_drift": {"coefficient": 0.001},
                                            "viscous_flow": {"rate": 3e-5}},
                                    duration=1800, rate=4, program="staircase", seed=8))
    d = diagnose(syn.record)
    assert {f.effect for f in d.findings} == {"thermal_drift", "viscous_flow"}
    steps = [t for t in d.trials if t.outcome == "accepted"]
    assert [t.step for t in steps] == [1, 2]


def test_no_candidate_explains_it_so_unexplained():
    """A static nonlinearity with only flow allowed as a candidate: structure remains that no
    candidate explains; the misfit is far above the noise floor, so the answer is
    'unexplained', not a forced name and not 'none'."""
    syn = synth.generate(synth.Spec(hidden={"static_nonlinearity": {"a2": 0.04, "a3": 0.0}},
                                    duration=1500, rate=4, program="staircase", seed=5))
    d = diagnose(syn.record, candidates=["viscous_flow"])
    assert d.cause == "unexplained"
    assert all(f.effect != "viscous_flow" for f in d.findings)
    out = d.to_dict()
    assert out["baseline"]["misfit_ratio"] > 1.5
    assert out["findings"][-1]["effect"] == "unexplained"
    assert out["findings"][-1]["parameters"]["misfit_ratio"] > 1.5


def test_clean_record_is_at_its_noise_floor():
    """No hidden effect: the floor, measured without the model, matches the true noise, the
    baseline's misfit ratio is near 1, and the verdict is none."""
    white = 5e-4
    syn = synth.generate(synth.Spec(duration=1500, rate=5, program="staircase", seed=8,
                                    noise=synth.NoiseSpec(white=white)))
    d = diagnose(syn.record, max_samples=None)
    out = d.to_dict()
    assert out["cause"] == "none"
    assert out["noise_floor"] == pytest.approx(white, rel=0.1)
    assert "window" in out["noise_floor_method"]
    assert 0.9 < out["baseline"]["misfit_ratio"] < 1.1
    assert out["explained_share"] is None or out["explained_share"] <= 1.0
    # 7,501 samples, above DIAGNOSE_MAX_SAMPLES: diagnosed as means of pairs, whose floor it gives
    reduced = diagnose(syn.record).to_dict()
    assert reduced["record"]["n_samples"] < 0.55 * len(syn.record)
    assert reduced["cause"] == "none"
    assert reduced["noise_floor"] == pytest.approx(white / np.sqrt(2), rel=0.1)


def test_relaxation_record_fits_and_is_none():
    """A record that relaxes (beta < 0, read under imposed displacement) fits with beta < 0 and
    is diagnosed as cleanly as a creeping one."""
    syn = synth.generate(synth.Spec(beta=(-0.05,), tau=(60.0,), duration=1500, rate=5,
                                    program="staircase", seed=9, noise=synth.NoiseSpec(white=5e-4)))
    d = diagnose(syn.record)
    assert d.cause == "none"
    assert d.baseline.betas[0] == pytest.approx(-0.05, rel=0.1)


def test_relaxation_with_a_further_relaxation_term_is_named():
    """An extra term of the record's own (negative) sign is not refused as unphysical."""
    syn = synth.generate(synth.Spec(beta=(-0.04,), tau=(20.0,),
                                    hidden={"extra_retardation": {"beta": -0.04, "tau": 400.0}},
                                    duration=3000, rate=2, program="staircase", seed=10,
                                    noise=synth.NoiseSpec(white=3e-4)))
    d = diagnose(syn.record)
    assert d.cause == "extra_retardation", d.to_dict()["tried"]
    assert d.findings[0].parameters["beta"] < 0
    order = np.argsort(d.extended.taus)
    assert d.extended.taus[order] == pytest.approx([20.0, 400.0], rel=0.3)
    assert d.extended.betas[order] == pytest.approx([-0.04, -0.04], rel=0.3)
    assert not any("unphysical" in t.outcome for t in d.trials if t.effect == "extra_retardation")


def test_record_starting_loaded_without_effect_is_none():
    syn = synth.generate(synth.Spec(duration=1500, rate=5, program="step", start_loaded=True, seed=6,
                                    noise=synth.NoiseSpec(white=5e-4)))
    assert syn.record.load[0] != 0
    assert diagnose(syn.record).cause == "none"


def test_a_correction_that_finds_no_load_is_not_measured_and_says_so(monkeypatch):
    """Where the extended model's correction does not settle, the diagnosis measures no
    correction error for it (one stopped half-way is not the model's): no ratio, the reason in
    the gain and in the finding's note, and the finding keeps its place."""
    from creepcomp.diagnose import effects, sensor

    syn = synth.generate(synth.Spec(hidden={"viscous_flow": {"rate": 4e-5}}, duration=1200, rate=4,
                                    program="staircase", seed=2))
    real = effects.compensate_extended

    def unsettled(*args, **kwargs):
        model = args[2]
        # (one step of the defect correction leaves an extended model's inverse unsettled)
        return real(*args, **(dict(kwargs, max_iterations=1) if model.extensions else kwargs))

    monkeypatch.setattr(sensor, "compensate_extended", unsettled)
    d = diagnose(syn.record)
    assert d.cause == "viscous_flow"
    assert d.gain["correction_error_ratio"] is None and d.gain["correction_error_extended"] is None
    assert "of its largest after 1 iterations" in d.gain["correction_unsettled"]
    f = d.findings[0]
    assert f.correction_error_ratio is None and not f.worsens_correction
    assert "finds no load that gives the signal" in f.note and "not measured" in f.note
    out = d.to_dict()
    assert out["gain"]["correction_error_ratio"] is None and out["findings"][0]["note"] == f.note
    from creepcomp.report.diagnosis import render_html
    html = render_html(d, {"signal": "V", "load": "N"})
    assert "creep correction finds no load that gives the signal" in html and "after 1 iterations" in html


def test_compensate_extended_refuses_an_unsettled_inverse_only_when_asked():
    from creepcomp.diagnose.effects import UnsettledInverse, compensate_extended
    from creepcomp.model import CreepModel

    t = np.arange(0.0, 600.0, 0.5)
    load = np.where(t >= 100.0, 1.0, 0.0)
    model = CreepModel([0.03], [40.0], 1.0, 0.0, {"viscous_flow": {"rate": 4e-5}})
    from creepcomp.diagnose.effects import simulate_extended
    signal = simulate_extended(model, t, load, None, "relaxed", "linear")
    with pytest.warns(RuntimeWarning, match="after 1 iterations.*the last step's"):
        loose = compensate_extended(t, signal, model, max_iterations=1)   # (what one step gives)
    assert np.all(np.isfinite(loose))
    with pytest.raises(UnsettledInverse) as caught:
        compensate_extended(t, signal, model, max_iterations=1, converge=True)
    assert "after 1 iterations" in caught.value.why and "viscous_flow" in str(caught.value)
    found = compensate_extended(t, signal, model, converge=True)
    np.testing.assert_allclose(found, load, atol=1e-6)
    # settled within the default steps: the default's result, bit for bit, and no warning
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        np.testing.assert_array_equal(found, compensate_extended(t, signal, model))


def test_a_correction_is_given_up_only_where_its_rate_cannot_settle_it():
    """The diagnosis's correction check stops early only where the steps' rate over the last
    RATE_WINDOW would need more than twice the strict budget: a stuck level and a slow
    decline stop, a flow's geometric settling goes on."""
    from creepcomp.diagnose.effects import RATE_WINDOW, _too_slow

    n = 60
    stuck = [6e-5] * n
    flow = list(1e-5 * 0.979 ** np.arange(n))              # settles below 1e-6 in about 110
    slow = list(1.7e-3 * 0.99 ** np.arange(n))             # would need about 680 more
    assert _too_slow(stuck, 1e-6, 740)
    assert not _too_slow(flow, 1e-6, 740)
    assert _too_slow(slow, 1e-6, 600) and not _too_slow(slow, 1e-6, 700)
    assert not _too_slow(stuck[:RATE_WINDOW], 1e-6, 740)     # (too few steps to read a rate)


def test_a_candidate_its_quick_fit_ranks_low_is_refined_and_can_be_the_best():
    # a tanh saturation on a staircase: its quick fit (the baseline held) lowers BIC by about
    # 3,700, fifth of the candidates, but refined by 13,000, more than the play hysteresis
    # refined among the best three (10,000); left unrefined, the hysteresis was accepted and
    # the saturation came second
    spec = synth.Spec(hidden={"static_nonlinearity": {"form": "tanh", "saturation": 0.32904587129023505}},
                      beta=(0.015757235202515964,), tau=(38.358580172405,), gain=3.2913720096484,
                      offset=0.9209297769410206, rate=3.992916388043164, duration=1252.2175558127287,
                      program="staircase", full_scale=9.81,
                      noise=synth.NoiseSpec(white=0.019404606091458925, correlation_time=4.341763942164884,
                                            lsb=0.0054346818098620015),
                      temperature=True, seed=7015)
    record = synth.generate(spec).record
    d = diagnose(record, correction=False)
    assert d.cause == "static_nonlinearity"
    assert "rate_independent_hysteresis" not in [f.effect for f in d.findings]


def test_the_decision_rule_asks_for_costly_inputs_only_when_it_needs_them():
    from types import SimpleNamespace as NS

    from creepcomp.diagnose.decision import gate, judge
    from creepcomp.fit.evidence import Evidence

    def never():
        raise AssertionError("asked, but not needed")

    current = NS(bic=0.0)
    rich = NS(effect=NS(name="rich"), delta_bic=-100.0, fit=NS(n_params=6, bic=-100.0),
              evidence=Evidence(-100.0, 1.2, 5.0))
    simple = NS(effect=NS(name="simple"), delta_bic=-60.0, fit=NS(n_params=5, bic=-60.0),
                evidence=Evidence(-60.0, 1.1, 4.0))
    weak = NS(effect=NS(name="weak"), delta_bic=-40.0, fit=NS(n_params=5, bic=-40.0),
              evidence=Evidence(-40.0, 1.01, 1.0))
    assert gate(NS(delta_bic=-5.0), None, current) == "not supported (BIC)"
    assert gate(simple, rich, current) is None                       # simpler, over half the ΔBIC
    assert gate(weak, rich, current) == "weaker than the accepted one"
    assert judge(weak, None, never, never).outcome == "not supported (held-out)"
    assert judge(rich, None, lambda: True, never).stop
    first = judge(rich, None, lambda: False, never)
    assert first.accept and first.outcome == "accepted"
    assert not judge(simple, rich, never, lambda: True).accept       # the richer one predicts better
    replaced = judge(simple, rich, never, lambda: False)
    assert replaced.accept and replaced.demoted.endswith("than the simpler simple")
