import numpy as np
import pytest

from creepcomp.analog.faults import CIRCUIT_EFFECTS, apply_fault, suggest_fixes
from creepcomp.errors import InputError
from creepcomp.model import CreepModel
from creepcomp.network import Cell, Network
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
