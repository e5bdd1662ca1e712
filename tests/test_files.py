import json

import pytest

from creepcomp.errors import InputError
from creepcomp.io.jsonfiles import Design, read_design, read_model, write_design, write_model
from creepcomp.model import CreepModel
from creepcomp.network import Cell, Network


def test_design_round_trip(tmp_path):
    d = Design(CreepModel.voigt(0.03, 45.0), Network((Cell(3e6, 15e-6),), 1e8), {"rule": "exact"})
    p = write_design(tmp_path / "d.json", d)
    back = read_design(p)
    assert back.network == d.network and back.model == d.model and back.extra["rule"] == "exact"
    assert json.loads(p.read_text())["load_resistance"] is None


def test_model_file_round_trip_and_design_creep_block(tmp_path):
    m = CreepModel((0.01, 0.02), (5.0, 50.0), gain=3.0, offset=0.1)
    assert read_model(write_model(tmp_path / "m.json", m)) == m
    d = Design(m, Network((Cell(1e6, 5e-6), Cell(2e6, 2.5e-5)), 1e8))
    assert read_model(write_design(tmp_path / "d.json", d)).beta == m.beta


@pytest.mark.parametrize("text,match", [
    ("{not json", "not valid JSON at line 1"),
    ("[1, 2]", "expected one JSON object"),
    ('{"cells": [{"R": 1e6, "C": 1e-5}], "R2": 1e8}', "missing 'creep'"),
    ('{"creep": {"beta": [0.03], "tau": [45]}, "cells": [{"R": 0, "C": 1e-5}], "R2": 1e8}',
     r"cells\[0\].R"),
    ('{"creep": {"beta": [0.03]}, "cells": [{"R": 1, "C": 1e-5}], "R2": 1e8}', "missing 'tau'"),
])
def test_bad_design_files_are_named(tmp_path, text, match):
    p = tmp_path / "bad.json"
    p.write_text(text)
    with pytest.raises(InputError, match=match) as info:
        read_design(p)
    assert "bad.json" in str(info.value)
