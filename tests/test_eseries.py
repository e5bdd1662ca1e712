import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from creepcomp.analog import eseries
from creepcomp.errors import InputError


def test_table_series_are_the_standard_not_the_formula():
    e24 = eseries.series_values("E24")
    assert len(e24) == 24
    assert e24[10:13] == (2.7, 3.0, 3.3)          # the formula would give 2.6, 2.9, 3.2
    assert eseries.series_values("e12") == (1.0, 1.2, 1.5, 1.8, 2.2, 2.7, 3.3, 3.9, 4.7, 5.6, 6.8, 8.2)
    assert eseries.series_values("E6") == (1.0, 1.5, 2.2, 3.3, 4.7, 6.8)
    assert eseries.series_values("E3") == (1.0, 2.2, 4.7)
    formula = [round(10 ** (i / 24), 1) for i in range(24)]
    assert list(e24) != formula


def test_e192_is_rounded_geometric_except_920():
    e192 = eseries.series_values("E192")
    assert len(e192) == 192
    for i, v in enumerate(e192):
        expected = 9.20 if i == 185 else round(10 ** (i / 192), 2)
        assert v == pytest.approx(expected, abs=1e-12), i


def test_e48_e96_are_subsets_of_e192():
    e192 = set(eseries.series_values("E192"))
    for name, n in (("E48", 48), ("E96", 96)):
        vals = eseries.series_values(name)
        assert len(vals) == n and set(vals) <= e192


def test_unknown_series_names_the_choices():
    with pytest.raises(InputError, match="E7.*E3, E6, E12, E24, E48, E96, E192"):
        eseries.series_values("E7")


def test_values_in_range_span_decades():
    vals = eseries.values_in_range("E6", 1e-6, 100e-6)
    assert vals[0] == 1e-6 and vals[-1] == 100e-6
    assert len(vals) == 13
    assert 4.7e-6 in vals and 47e-6 in vals


@given(st.floats(1e-12, 1e12), st.sampled_from(list(eseries.SERIES)))
def test_nearest_is_a_series_value_and_nearest_on_log_scale(value, name):
    n = eseries.nearest(value, name)
    mantissa = n / 10 ** math.floor(math.log10(n) + 1e-12)
    assert any(abs(mantissa - m) < 1e-9 for m in eseries.series_values(name) + (10.0,))
    nb = eseries.neighbours(value, name, 2)
    assert abs(math.log(n / value)) <= min(abs(math.log(v / value)) for v in nb) + 1e-12


@given(st.floats(1e-9, 1e9), st.sampled_from(list(eseries.SERIES)), st.integers(1, 3))
def test_neighbours_bracket_the_value(value, name, count):
    nb = eseries.neighbours(value, name, count)
    assert np.all(np.diff(nb) > 0)
    assert np.sum(nb < value * (1 - 1e-12)) == count
    assert np.sum(nb >= value * (1 - 1e-12)) in (count, count + 1)
