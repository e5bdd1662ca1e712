"""Part technologies, thermistors and a network's values over temperature."""

import numpy as np
import pytest

from creepcomp.analog.parts import (DIELECTRICS, NTC_THERMISTORS, PART_REFERENCE, RESISTORS, PartsPlan,
                                    ThermistorUse, network_at, ntc_resistance)
from creepcomp.errors import InputError
from creepcomp.network import Cell, Network


def test_every_table_entry_names_its_source():
    for table in (RESISTORS.values(), DIELECTRICS.values(), NTC_THERMISTORS):
        for entry in table:
            assert entry.source


def test_ntc_law_at_25_and_its_slope():
    assert ntc_resistance(10e3, 3380.0, 25.0) == pytest.approx(10e3)
    # alpha = -B / T^2 at 25 C
    d = (ntc_resistance(10e3, 3380.0, 25.01) - ntc_resistance(10e3, 3380.0, 24.99)) / 0.02 / 10e3
    assert d == pytest.approx(-3380.0 / 298.15 ** 2, rel=1e-4)


def test_network_at_moves_fixed_parts_by_their_tc_and_thermistors_by_their_law():
    net = Network((Cell(100e3, 10e-6), Cell(1e6, 1e-6)), 2e6)
    therm = ThermistorUse("x", 100e3, 4250.0, series=1e3, parallel=1e6)
    plan = PartsPlan(resistor_tc=50e-6, capacitor_tc=-200e-6, thermistors={"R1.1": therm})
    hot = network_at(net, plan, 45.0)
    assert hot.cells[1].R == pytest.approx(1e6 * (1 + 50e-6 * 20))
    assert hot.cells[0].C == pytest.approx(10e-6 * (1 - 200e-6 * 20))
    r = 1e3 + ntc_resistance(100e3, 4250.0, 45.0)
    assert hot.cells[0].R == pytest.approx(r * 1e6 / (r + 1e6))
    assert network_at(net, PartsPlan(thermistors={}), PART_REFERENCE) == net
    with pytest.raises(InputError, match="R5 is not a resistor"):
        network_at(net, PartsPlan(thermistors={"R5": therm}), 20.0)


def test_parts_block_round_trip_and_errors():
    plan = PartsPlan("thick film", "polyester", 0.05, 0.1, 100e-6, 400e-6,
                     {"R2": ThermistorUse("Murata NCP18WF104", 100e3, 4250.0)})
    assert PartsPlan.from_dict(plan.to_dict()) == plan
    assert plan.tracking == "ntc" and PartsPlan().tracking == "none"
    with pytest.raises(InputError, match="technology 'carbon'"):
        PartsPlan.from_dict({"resistors": {"technology": "carbon"}})
    with pytest.raises(InputError, match="R25"):
        PartsPlan.from_dict({"thermistors": {"R1": {"B": 4000}}})
    assert np.isfinite(DIELECTRICS["polyester"].insulation_time(85.0))
