"""One default in one place: the command line's defaults are the API's, read back through the
command's own parsing (Typer's parameters against ``inspect.signature``)."""

import inspect

import pytest
import typer.main

from creepcomp.analog.network_design import design_network
from creepcomp.analog.parts import PartsPlan
from creepcomp.analog.sizing import size
from creepcomp.cli import app, register_commands
from creepcomp.cli.common import quantity, value_range
from creepcomp.cli.size import parts_plan, series_option, size_options
from creepcomp.temperature import TemperatureLaw


def command_defaults(name: str) -> dict:
    """Each parameter of a command and its default, as Typer gives them to click."""
    register_commands([name])
    command = typer.main.get_command(app).commands[name]
    return {p.name: p.default for p in command.params}


def api_defaults(function) -> dict:
    return {k: p.default for k, p in inspect.signature(function).parameters.items()
            if p.default is not inspect.Parameter.empty}


CLI = command_defaults("size")
SIZE = api_defaults(size)
DESIGN = api_defaults(design_network)


#: size()'s argument of each option, and how the command reads the option's text.
SIZE_OPTIONS = {
    "rule": ("rule", str),
    "series": ("resistor_series", lambda t: series_option(t, "--series")),
    "cap_series": ("capacitor_series", lambda t: series_option(t, "--cap-series")),
    "cap_range": ("cap_range", lambda t: value_range(t, "farad", "--cap-range")),
    "res_range": ("res_range", lambda t: value_range(t, "ohm", "--res-range")),
    "capacitance": ("capacitance", lambda t: quantity(t, "farad", "--capacitance")),
    "source_resistance": ("source_resistance", lambda t: quantity(t, "ohm", "--source-resistance")),
    "load_resistance": ("load_resistance", lambda t: quantity(t, "ohm", "--load-resistance", allow_none=True)),
    "sweep_period": ("sweep_period", lambda t: quantity(t, "second", "--sweep-period")),
}


@pytest.mark.parametrize("option", sorted(SIZE_OPTIONS))
def test_a_sizing_options_default_is_the_apis(option):
    argument, parse = SIZE_OPTIONS[option]
    got = parse(CLI[option]) if CLI[option] is not None else None
    assert got == pytest.approx(SIZE[argument]) if isinstance(got, tuple) else got == SIZE[argument]


def test_the_commands_parsing_of_the_defaults_gives_sizes_defaults():
    got = size_options(**{k: CLI[k] for k in SIZE_OPTIONS})
    assert set(got) == {argument for argument, _ in SIZE_OPTIONS.values()}
    for argument, value in got.items():
        assert value == (pytest.approx(SIZE[argument]) if isinstance(value, tuple) else SIZE[argument])


@pytest.mark.parametrize("option", ["tracking", "topology", "allow_impractical"])
def test_a_design_options_default_is_the_apis(option):
    assert CLI[option] == DESIGN[option]


def test_the_parts_options_give_the_default_plan():
    plan = parts_plan(CLI["resistor_technology"], CLI["dielectric"], CLI["resistor_tolerance"],
                      CLI["capacitor_tolerance"])
    assert plan == PartsPlan()


def test_the_reference_temperature_is_the_laws():
    assert float(CLI["reference_temperature"]) == api_defaults(TemperatureLaw.arrhenius)["reference"]


def test_every_option_with_a_default_is_compared():
    """A new option with a default must be added above (or its default is written twice)."""
    compared = set(SIZE_OPTIONS) | {"tracking", "topology", "allow_impractical", "resistor_technology",
                                    "dielectric", "reference_temperature"}
    with_default = {k for k, v in CLI.items() if v is not None} - {"as_json"}
    assert with_default <= compared


def test_a_changed_api_default_changes_the_command_line(monkeypatch):
    """The defaults are read, not copied: another API default gives another option default."""
    import creepcomp.cli.size as size_module

    source = inspect.getsource(size_module._api_defaults)
    assert '"E24"' not in source and "1u:100u" not in source and '"exact"' not in source
    monkeypatch.setattr(size_module, "size", lambda model, rule="paper", resistor_series="E12",
                        capacitor_series="E6", cap_range=(1e-9, 1e-6), res_range=(10.0, 1e9),
                        capacitance=None, source_resistance=0.0, load_resistance=None,
                        sweep_period=None, plan=None: None)
    got = size_module._api_defaults()
    assert (got["rule"], got["series"], got["cap_range"]) == ("paper", "E12", "1n:1u")


# --- the other commands: each default that has an API counterpart -------------------------------

def _api(dotted: str):
    """The default of ``module.function.parameter``."""
    import importlib

    module, function, parameter = dotted.rsplit(".", 2)
    return api_defaults(getattr(importlib.import_module(module), function))[parameter]


def _volts(text):
    return quantity(text, "volt", "--signal")


def _seconds(text):
    return quantity(text, "second", "--loading-time")


#: (command, option, the API's parameter, how the command reads the option's text)
COUNTERPARTS = [
    ("netlist", "program", "creepcomp.verify.compare.compare_program.program", str),
    ("netlist", "points", "creepcomp.verify.compare.compare_program.points", int),
    ("netlist", "signal", "creepcomp.verify.compare.compare_program.signal", _volts),
    ("simulate", "program", "creepcomp.verify.compare.compare_program.program", str),
    ("simulate", "points", "creepcomp.verify.compare.compare_program.points", int),
    ("simulate", "signal", "creepcomp.verify.compare.compare_program.signal", _volts),
    ("mc", "metric", "creepcomp.verify.tolerance_analysis.analyse.metric", str),
    ("mc", "worst", "creepcomp.verify.tolerance_analysis.analyse.worst", bool),
    ("mc", "sensitivity_n", "creepcomp.verify.tolerance_analysis.analyse.sensitivity_samples", int),
    ("mc", "distribution", "creepcomp.verify.tolerances.Tolerance.distribution", str),
    ("creep-test", "loading_time", "creepcomp.verify.creep_test.CreepTestProgram.loading_time", _seconds),
    ("creep-test", "rate", "creepcomp.verify.creep_test.digital_test.rate", float),
    ("correct", "method", "creepcomp.digital.correctors.compensate.method", str),
    ("correct", "hold", "creepcomp.digital.correctors.compensate.hold", str),
    ("firmware", "method", "creepcomp.digital.firmware.generate_firmware.method", str),
    ("firmware", "precision", "creepcomp.digital.firmware.generate_firmware.precision", str),
    ("firmware", "name", "creepcomp.digital.firmware.generate_firmware.name", str),
    ("fit", "initial", "creepcomp.diagnose.fitting.fit.initial", str),
    ("fit", "duplicate_times", "creepcomp.diagnose.fitting.fit.duplicate_times", str),
    ("fit", "max_terms", "creepcomp.diagnose.fitting.fit.max_terms", int),
    ("fit", "flow", "creepcomp.diagnose.fitting.fit.flow", bool),
    ("diagnose", "initial", "creepcomp.diagnose.sensor.diagnose.initial", str),
    ("diagnose", "duplicate_times", "creepcomp.io.records.read_record.duplicate_times", str),
    ("diagnose", "spice_check", "creepcomp.diagnose.circuit.diagnose_circuit.spice_check", bool),
]


@pytest.mark.parametrize("command, option, parameter, parse", COUNTERPARTS)
def test_a_commands_default_is_its_api_counterparts(command, option, parameter, parse):
    text = command_defaults(command)[option]
    assert parse(text) == _api(parameter)
