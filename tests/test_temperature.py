"""The temperature law of the creep model."""

import json

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from creepcomp.errors import InputError
from creepcomp.model import CreepModel
from creepcomp.temperature import GAS_CONSTANT, TemperatureLaw, temperature_grid


def test_arrhenius_shift_halves_tau_about_every_10_K_at_43_kJ():
    law = TemperatureLaw.arrhenius(43e3, reference=20.0)
    assert law.shift(20.0) == pytest.approx(1.0)
    ratio = law.shift(30.0) / law.shift(20.0)
    assert ratio == pytest.approx(np.exp(43e3 / GAS_CONSTANT * (1 / 303.15 - 1 / 293.15)))
    assert 0.5 < ratio < 0.6
    assert law.shift(-10.0) / law.shift(40.0) == pytest.approx(
        np.exp(43e3 / GAS_CONSTANT * (1 / 263.15 - 1 / 313.15)))


def test_wlf_shift_and_singularity():
    law = TemperatureLaw(20.0, "wlf", c1=17.4, c2=51.6)
    assert law.shift(30.0) == pytest.approx(10 ** (-17.4 * 10 / 61.6))
    with pytest.raises(InputError, match="singularity"):
        law.shift(20.0 - 51.6)


def test_kappa_round_trip():
    law = TemperatureLaw.from_kappa(0.06, 25.0)
    assert law.kappa == pytest.approx(0.06)
    assert law.activation_energy == pytest.approx(0.06 * GAS_CONSTANT * 298.15 ** 2)


@pytest.mark.parametrize("bad, match", [
    ({"reference": -300.0, "law": "arrhenius", "activation_energy": 1.0}, "absolute zero"),
    ({"reference": 20.0, "law": "arrhenius"}, "activation_energy"),
    ({"reference": 20.0, "law": "arrhenius", "activation_energy": -5.0}, ">= 0"),
    ({"reference": 20.0, "law": "wlf", "c1": 10.0}, "c1' and 'c2'"),
    ({"reference": 20.0, "law": "vft", "activation_energy": 1.0}, "law"),
    ({"law": "arrhenius", "activation_energy": 1.0}, "reference"),
])
def test_bad_law_names_the_key(bad, match):
    with pytest.raises(InputError, match=match):
        CreepModel.from_dict({"beta": [0.03], "tau": [45.0], "temperature": bad}, where="m.json")


def test_model_file_round_trip_keeps_the_law():
    law = TemperatureLaw.arrhenius(43e3, 20.0, beta_per_kelvin=[1e-3, -2e-3])
    m = CreepModel((0.02, 0.01), (10.0, 300.0), 2e-4, 0.1, {}, law)
    back = CreepModel.from_dict(json.loads(json.dumps(m.to_dict())))
    assert back == m
    assert back.to_dict()["temperature"] == {"reference": 20.0, "law": "arrhenius",
                                             "activation_energy": 43e3,
                                             "beta_per_kelvin": [1e-3, -2e-3]}
    with pytest.raises(InputError, match="beta_per_kelvin has 2 entries for 1"):
        CreepModel((0.03,), (45.0,), temperature=law)


def test_design_file_creep_block_carries_the_law(tmp_path):
    from creepcomp.analog.sizing import size
    from creepcomp.io.jsonfiles import Design, read_design, write_design
    m = CreepModel((0.03,), (45.0,), temperature=TemperatureLaw.arrhenius(43e3))
    report = size(m)
    assert report.design_dict()["creep"]["temperature"]["activation_energy"] == 43e3
    write_design(tmp_path / "d.json", Design(m, report.chosen))
    assert read_design(tmp_path / "d.json").model.temperature == m.temperature


@settings(max_examples=25, deadline=None)
@given(st.floats(-20.0, 60.0), st.floats(10e3, 120e3))
def test_constant_temperature_response_is_the_model_at_that_temperature(temp, ea):
    m = CreepModel((0.02, 0.01), (10.0, 300.0), 2.0, 0.5,
                   temperature=TemperatureLaw.arrhenius(ea, 20.0, beta_per_kelvin=[2e-3, -1e-3]))
    t = np.linspace(0.0, 900.0, 901)
    load = np.where(t >= 100.0, 1.0, 0.0)
    y = m.response(t, load, temperature=np.full_like(t, temp))
    assert np.max(np.abs(y - m.at_temperature(temp).response(t, load))) < 1e-12


def test_a_temperature_needs_a_law():
    m = CreepModel.voigt(0.03, 45.0)
    with pytest.raises(InputError, match="no temperature law"):
        m.response([0.0, 1.0], [0.0, 1.0], temperature=[20.0, 20.0])
    assert m.at_temperature(50.0) is m


def test_temperature_grid_includes_limits_every_5_K():
    g = temperature_grid(-10.0, 40.0)
    assert g[0] == -10.0 and g[-1] == 40.0 and np.max(np.diff(g)) <= 5.0 + 1e-12
    assert len(temperature_grid(-10.0, 41.0)) == 12
    with pytest.raises(InputError):
        temperature_grid(40.0, -10.0)
