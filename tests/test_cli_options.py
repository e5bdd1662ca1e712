"""The command line's options: creep terms, counts, the version, the help's groups."""

import json
import re
from importlib.metadata import version

import pytest
import typer

from creepcomp.cli.common import count
from creepcomp.errors import InputError
from creepcomp.io.jsonfiles import write_design

#: A small one-cell design (the default sensor's exact network, E24/E6 parts).
DESIGN = {"creep": {"beta": [0.03], "tau": [45.0]}, "cells": [{"R": 4.7e6, "C": 1e-5}],
          "R2": 1.5e8, "source_resistance": 0.0, "load_resistance": None}


def test_term_options_make_a_model_of_several_terms(run_cli):
    status, out, err = run_cli("size", "--term", "3%@45s", "--term", "1%@2min", "--json")
    assert status == 0, err
    data = json.loads(out)
    assert data["creep"]["beta"] == [0.03, 0.01] and data["creep"]["tau"] == [45.0, 120.0]
    assert len(data["cells"]) == 2
    status, out, err = run_cli("size", "--term", "3%@45s", "--term", "1%@2min")
    assert status == 0, err
    assert "2 creep terms (3 % at 45 s, 1 % at 2 min)" in out


def test_one_term_options_still_work(run_cli):
    status, out, err = run_cli("size", "--beta0", "3%", "--tau", "45s")
    assert status == 0, err
    assert "1 creep term (3 % at 45 s)" in out


@pytest.mark.parametrize("args,needle", [
    (["--beta0", "0.05%", "--tau", "20min", "--beta0", "0.02%", "--tau", "30s"], "--beta0 given 2 times"),
    (["--beta0", "3%", "--tau", "45s", "--tau", "30s"], "--tau given 2 times"),
    (["--term", "3%@45s", "--beta0", "3%"], "drop --beta0"),
    (["--term", "3%@45s", "--tau", "45s"], "drop --tau"),
    (["--term", "3%@45s", "--model", "m.json"], "drop --model"),
    (["--term", "3%"], "expected BETA@TAU"),
    (["--term", "3%@45s@1"], "expected BETA@TAU"),
    (["--term", "x@45s"], "--term 'x@45s': BETA"),
    (["--term", "3%@soon"], "--term '3%@soon': TAU"),
    (["--term", "3%@45s", "--term", "1%@0s"], "tau[1] = 0 s"),
])
def test_bad_creep_terms_are_one_line_and_status_2(run_cli, args, needle):
    status, out, err = run_cli("size", *args)
    assert status == 2 and needle in err, err
    assert len(err.strip().splitlines()) == 1 and out == ""


@pytest.mark.parametrize("text,expected", [("1e7", 10_000_000), ("20k", 20_000), ("100", 100),
                                           (5, 5), ("1.5k", 1500)])
def test_counts_take_engineering_notation(text, expected):
    assert count(text, "--n") == expected


@pytest.mark.parametrize("text,needle", [("1.5", "whole number"), ("0", "whole number >= 1"),
                                         ("-3", "whole number"), ("many", "cannot read")])
def test_a_count_is_a_whole_number_of_at_least_one(text, needle):
    with pytest.raises(InputError, match=needle):
        count(text, "--n")


def test_mc_takes_counts_in_engineering_notation(run_cli, tmp_path):
    design = write_design(tmp_path / "d.json", DESIGN)
    status, out, err = run_cli("mc", design, "--n", "2e3", "--sensitivity-n", "0.5k",
                               "--spot-check", "0", "--no-worst-case", "--json")
    assert status == 0, err
    data = json.loads(out)
    assert data["n"] == 2000 and data["tighter_parts"][0]["samples"] == 500


@pytest.mark.parametrize("option,value", [("--n", "1.5"), ("--n", "0"), ("--sensitivity-n", "2.5"),
                                          ("--spot-check", "-1"), ("--seed", "0.5")])
def test_mc_refuses_a_count_that_is_not_whole(run_cli, tmp_path, option, value):
    design = write_design(tmp_path / "d.json", DESIGN)
    status, out, err = run_cli("mc", design, option, value)
    assert status == 2 and f"{option} {value}: a count is a whole number" in err
    assert len(err.strip().splitlines()) == 1 and out == ""


def test_version_comes_from_the_package_metadata(run_cli):
    status, out, err = run_cli("--version")
    assert status == 0 and err == ""
    assert out.strip() == f"creepcomp {version('creepcomp')}"


def test_bare_command_prints_the_help_and_succeeds(run_cli):
    status, out, err = run_cli()
    assert status == 0 and err == ""
    assert "Usage" in out and "size" in out and "error:" not in out + err


def test_help_lists_the_commands_grouped_in_the_order_of_the_work(run_cli):
    from creepcomp.cli import COMMAND_GROUPS, register_commands
    from creepcomp.cli.common import app

    register_commands([])          # every command (a command alone imports only its own)

    registered = [info.name for info in app.registered_commands]
    grouped = [name for names in COMMAND_GROUPS.values() for name in names]
    assert set(registered) <= set(grouped), "a command without a group in COMMAND_GROUPS"
    assert registered == [name for name in grouped if name in registered]
    status, out, _ = run_cli("--help")
    assert status == 0
    panels = [m.group(1).strip() for m in re.finditer(r"╭─ ([\w ]+?) ─", out)]
    assert panels == ["Options"] + list(COMMAND_GROUPS)[:len(panels) - 1]
    assert set(panels[1:]) == {group for group, names in COMMAND_GROUPS.items()
                               if set(names) & set(registered)}
    listed = [m.group(1) for m in re.finditer(r"^│ ([a-z][\w-]+) ", out, re.MULTILINE)]
    assert listed == registered


def test_demo_takes_dash_o_and_keeps_out():
    from creepcomp.cli import register_commands
    from creepcomp.cli.common import app

    register_commands(["demo"])

    demo = typer.main.get_command(app).commands["demo"]
    [out] = [p for p in demo.params if p.name == "out"]
    assert {"-o", "--output", "--out"} <= set(out.opts)


def test_a_reduced_record_is_not_called_irregular():
    import numpy as np

    from creepcomp.cli.fit import describe_record
    from creepcomp.fit.data import prepare
    from creepcomp.fit.reduce import reduce_record
    from creepcomp.io.records import Record

    t = np.arange(60_000) * 0.01
    load = (t >= 100).astype(float)
    record = Record(time=t, load=load, signal=load * 1.01, source="uniform.csv")
    reduced, note = reduce_record(record, 5_000)
    assert note and not reduced.is_uniform
    line = describe_record(reduced, prepare(reduced))
    assert "reduced to block means" in line and "irregular" not in line
    assert "uniform" in describe_record(record, prepare(record))
