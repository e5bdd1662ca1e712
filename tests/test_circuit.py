import numpy as np
import pytest

from creepcomp.analog.faults import resistor_parts, suggest_fixes
from creepcomp.diagnose.circuit import CIRCUIT_EFFECTS, apply_fault, exact_equivalents
from creepcomp.errors import InputError
from creepcomp.model import CreepModel
from creepcomp.network import Branch, Cell, Network
from creepcomp.analog.quality import step_peak

MODEL = CreepModel.voigt(0.03, 45.0)
NOMINAL = Network((Cell(3e6, 15e-6),), 1e8, (), 0.0, None)


@pytest.mark.parametrize("effect,params,expected", [
    ("capacitor_value", {"C": 16.5e-6}, Network((Cell(3e6, 16.5e-6),), 1e8)),
    ("capacitor_leakage", {"R": 3e8}, Network((Cell(3e6, 15e-6, leakage=3e8),), 1e8)),
    ("dielectric_absorption", {"fraction": 0.01, "tau": 30.0},
     Network((Cell(3e6, 15e-6, absorption_R=30.0 / 15e-8, absorption_C=15e-8),), 1e8)),
    ("source_impedance", {"R": 2e5}, Network((Cell(3e6, 15e-6),), 1e8, (), 2e5)),
    ("load_impedance", {"R": 1e9}, Network((Cell(3e6, 15e-6),), 1e8, (), 0.0, 1e9)),
])
def test_each_fault_is_the_physical_change(effect, params, expected):
    got = apply_fault(NOMINAL, effect, params)
    w = np.logspace(-4, 1, 30)
    np.testing.assert_allclose(got.lag_expansion().frequency_response(w),
                               expected.lag_expansion().frequency_response(w), rtol=1e-12)
    assert effect in CIRCUIT_EFFECTS


def test_unknown_fault_and_bad_values():
    with pytest.raises(InputError, match="unknown circuit effect"):
        apply_fault(NOMINAL, "solder_joint", {})
    with pytest.raises(InputError, match="must be positive"):
        apply_fault(NOMINAL, "capacitor_value", {"C": -1})


def test_fixes_lower_the_residual_creep_with_series_parts():
    for effect, params in (("capacitor_value", {"C": 16.5e-6}), ("load_impedance", {"R": 1e9})):
        built = apply_fault(NOMINAL, effect, params)
        now = step_peak(MODEL, built)[0]
        fixes = suggest_fixes(built, MODEL)
        assert fixes and all(f.residual_creep_peak < now for f in fixes)
        assert fixes == sorted(fixes, key=lambda f: f.residual_creep_peak)
    fixes = suggest_fixes(apply_fault(NOMINAL, "load_impedance", {"R": 1e9}), MODEL)
    assert fixes[0].part == "R2" and fixes[0].value_to == 110e6
    assert suggest_fixes(apply_fault(NOMINAL, "capacitor_value", {"C": 16.5e-6}), MODEL)[0].value_to == 15e-6


def test_resistor_value_is_the_part_changed_and_its_exact_equivalents():
    w = np.logspace(-4, 1, 30)

    def response(net):
        return net.lag_expansion().frequency_response(w)

    low_r2 = apply_fault(NOMINAL, "resistor_value", {"R": 0.85e8, "part": "R2"})
    assert low_r2 == Network((Cell(3e6, 15e-6),), 0.85e8)
    # R2 15 % low is a load of 5.7 R2 (R2 || RL = 0.85 R2), R1 20 % low a leakage of 4 R1
    np.testing.assert_allclose(response(low_r2), response(apply_fault(NOMINAL, "load_impedance",
                                                                      {"R": 1e8 * 0.85 / 0.15})), rtol=1e-12)
    low_r1 = apply_fault(NOMINAL, "resistor_value", {"R": 0.8 * 3e6, "part": "R1"})
    np.testing.assert_allclose(response(low_r1), response(apply_fault(NOMINAL, "capacitor_leakage", {"R": 4 * 3e6})),
                               rtol=1e-12)
    assert set(exact_equivalents(NOMINAL, "resistor_value", "R2")) == {("load_impedance", None)}
    assert set(exact_equivalents(NOMINAL, "capacitor_leakage", "C1")) == {("resistor_value", "R1")}
    assert exact_equivalents(NOMINAL, "resistor_value", "R1") == [("capacitor_leakage", "C1")]
    # a lag network: the series R1 and a source resistance add; its shunt R3 is a part too
    lag = Network((Cell(62e3, 0.0),), None, (Branch(2e6, 22e-6),))
    assert resistor_parts(lag) == {"R1": 62e3, "R3": 2e6}
    assert exact_equivalents(lag, "source_impedance") == [("resistor_value", "R1")]
    assert apply_fault(lag, "resistor_value", {"R": 1.8e6, "part": "R3"}).shunt[0] == Branch(1.8e6, 22e-6)
    with pytest.raises(InputError, match="R4.*not a resistor.*R1, R3"):
        apply_fault(lag, "resistor_value", {"R": 1.0, "part": "R4"})


def test_fix_of_a_wrong_resistor_puts_the_series_value_back():
    built = apply_fault(NOMINAL, "resistor_value", {"R": 0.85e8, "part": "R2"})
    fix = suggest_fixes(built, MODEL)[0]
    assert (fix.part, fix.value_from, fix.value_to) == ("R2", 0.85e8, 1e8)
    assert fix.residual_creep_peak < 0.1 * step_peak(MODEL, built)[0]
    # a lag network (shunt capacitor C3 among the parts) is fixed too
    model = CreepModel((-0.03,), (45.0,))
    from creepcomp.analog.sizing import size

    nominal = size(model).chosen
    r3 = nominal.shunt[0].R
    built = apply_fault(nominal, "resistor_value", {"R": 1.2 * r3, "part": "R3"})
    fix = suggest_fixes(built, model)[0]
    assert fix.part == "R3" and fix.value_to == pytest.approx(r3)
