import math

import pytest

from creepcomp.errors import InputError
from creepcomp.units import format_quantity, parse_quantity


@pytest.mark.parametrize("text,kind,expected", [
    ("3%", "fraction", 0.03), ("2.7%", "fraction", 0.027), ("0.03", "fraction", 0.03),
    ("100ppm", "fraction", 1e-4), ("45s", "second", 45.0), ("45", "second", 45.0),
    ("2min", "second", 120.0), ("1h", "second", 3600.0), ("250ms", "second", 0.25),
    ("4.7k", "ohm", 4700.0), ("4k7", "ohm", 4700.0), ("4R7", "ohm", 4.7), ("150M", "ohm", 150e6),
    ("1meg", "ohm", 1e6), ("1 kΩ", "ohm", 1000.0), ("10mohm", "ohm", 0.01), ("1G", "ohm", 1e9),
    ("10u", "farad", 10e-6), ("4.7uF", "farad", 4.7e-6), ("100n", "farad", 100e-9),
    ("-0.5%", "fraction", -0.005),
])
def test_parse_examples(text, kind, expected):
    assert parse_quantity(text, kind) == expected


@pytest.mark.parametrize("text,kind", [
    ("nan", "fraction"), ("inf", "ohm"), ("1e999", "number"), ("3q", "fraction"), ("", "second"),
    ("abc", "farad"), ("10uF", "ohm"), ("4.7kohm", "second"), ("45 parsecs", "second"),
])
def test_parse_rejects_with_name(text, kind):
    with pytest.raises(InputError, match="--opt"):
        parse_quantity(text, kind, "--opt")


def test_parse_numbers_pass_through_but_not_nan():
    assert parse_quantity(0.5, "fraction") == 0.5
    with pytest.raises(InputError):
        parse_quantity(math.nan, "fraction")


@pytest.mark.parametrize("value,unit,expected", [
    (4.7e6, "Ω", "4.7 MΩ"), (1e-5, "F", "10 µF"), (0, "V", "0 V"), (None, "Ω", "none"),
    (150e6, "Ω", "150 MΩ"), (999.9999999, "Ω", "1 kΩ"),
])
def test_format(value, unit, expected):
    assert format_quantity(value, unit) == expected


def test_where_keeps_an_absolute_instant_to_a_tenth_of_a_second():
    """A data problem's ``where`` on a record whose clock reads 193 ks (the left insole file)
    tells its two jumps 290 s apart to 0.1 s, not as 193.2 ks and 193.5 ks."""
    from creepcomp.units import format_parameter

    assert format_parameter("where", [193229.366837, 193519.395]) == "193.2294 ks, 193.5194 ks"
    assert format_parameter("tau", 193229.366837) == "193.2 ks"
