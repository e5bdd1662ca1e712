import control
import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from creepcomp.errors import InputError
from creepcomp.network import Branch, Cell, Network


@given(st.floats(1e3, 1e8), st.floats(1e-8, 1e-4), st.floats(1e4, 1e9))
def test_single_cell_matches_the_physics_formula(r1, c, r2):
    """H(s) = R2 (1 + s R1 C) / (R1 + R2 + s R1 R2 C)  (physics.md, section 3)."""
    net = Network((Cell(r1, c),), r2)
    tau_p = c * r1 * r2 / (r1 + r2)
    w = np.logspace(-3, 3, 25) / tau_p
    s = 1j * w
    expected = r2 * (1 + s * r1 * c) / (r1 + r2 + s * r1 * r2 * c)
    np.testing.assert_allclose(net.lag_expansion().frequency_response(w), expected, rtol=1e-9)
    np.testing.assert_allclose(net.state_space()(s).ravel(), expected, rtol=1e-9)


def test_source_and_load_resistance_enter_as_the_physics_says():
    r1, c, r2, rs, rl = 4.7e6, 10e-6, 150e6, 1e5, 1e9
    net = Network((Cell(r1, c),), r2, (), rs, rl)
    r2p = r2 * rl / (r2 + rl)
    w = np.logspace(-4, 0, 20)
    zc = r1 / (1 + 1j * w * r1 * c)
    expected = r2p / (rs + zc + r2p)
    np.testing.assert_allclose(net.lag_expansion().frequency_response(w), expected, rtol=1e-10)


def test_lag_network_with_shunt_branches():
    net = Network((Cell(1e6, 0.0),), None, (Branch(2e6, 5e-6), Branch(3e5, 1e-6)), 1e3, 1e9)
    w = np.logspace(-4, 2, 30)
    s = 1j * w
    y = 1 / 1e9 + sum(s * b.C / (1 + s * b.R * b.C) for b in net.shunt)
    expected = (1 / y) / (1e3 + 1e6 + 1 / y)
    np.testing.assert_allclose(net.lag_expansion().frequency_response(w), expected, rtol=1e-10)
    np.testing.assert_allclose(control.ss2tf(net.state_space())(s), expected, rtol=1e-8)


def test_parts_round_trip():
    net = Network((Cell(1e6, 1e-5), Cell(2e6, 3e-6)), 5e7)
    labels = [p[0] for p in net.parts()]
    assert labels == ["R1.1", "C1.1", "R1.2", "C1.2", "R2"]
    assert net.with_parts([p[2] for p in net.parts()]) == net
    assert Network.from_dict(net.to_dict()) == net


@pytest.mark.parametrize("data,match", [
    ({"cells": [{"R": -1, "C": 1e-6}], "R2": 1e6}, r"cells\[0\].R"),
    ({"cells": [{"R": 1e6, "C": 1e-6}]}, "missing 'R2'"),
    ({"cells": [], "R2": 1e6}, "non-empty"),
    ({"cells": [{"R": 1e6}], "R2": 1e6}, "'R' and 'C'"),
    ({"cells": [{"R": 1e6, "C": 1e-6}], "R2": 1e6, "source_resistance": -5}, "source_resistance"),
    ({"cells": [{"R": "x", "C": 1e-6}], "R2": 1e6}, "not a number"),
])
def test_bad_network_data_is_named(data, match):
    with pytest.raises(InputError, match=match):
        Network.from_dict(data)


def test_capacitor_leakage_and_absorption_follow_the_impedance():
    r, c, r_leak, r_da, c_da, r2 = 3e6, 15e-6, 1e9, 2e7, 3e-7, 1e8
    net = Network((Cell(r, c, leakage=r_leak, absorption_R=r_da, absorption_C=c_da),), r2)
    w = np.logspace(-5, 1, 40)
    s = 1j * w
    y_cell = 1 / r + s * c + 1 / r_leak + s * c_da / (1 + s * r_da * c_da)
    expected = r2 / (r2 + 1 / y_cell)
    np.testing.assert_allclose(net.lag_expansion().frequency_response(w), expected, rtol=1e-9)
    assert len(net.lag_expansion().taus) == 2
    back = Network.from_dict(net.to_dict())
    assert back == net and back.cells[0].ideal() == Cell(r, c)
    assert [p[0] for p in net.parts()] == ["R1", "C1", "R2"]
    with pytest.raises(InputError, match="both absorption_R and absorption_C"):
        Cell(r, c, absorption_R=1e6)
