"""The bundled records by name: ``creepcomp data list`` and ``data export NAME [DIR]``, and
``creepcomp.data.records``/``record``/``export`` behind them."""

import json

import numpy as np
import pytest

from creepcomp import data, read_record
from creepcomp.errors import InputError


def test_every_bundled_record_is_listed_with_its_samples(run_cli):
    status, out, _ = run_cli("data", "list", "--json")
    assert status == 0
    rows = json.loads(out)["records"]
    assert [r["name"] for r in rows] == list(data.RECORDS)
    shipped = {p.name for p in data.path("real/wood").iterdir() if p.name.endswith(".csv")}
    assert {data.RECORDS[r["name"]].file.split("/")[-1] for r in rows} >= shipped
    for row in rows:
        assert row["samples"] == len(data.record(row["name"]).read())
        assert row["licence"] and row["description"]
    status, text, _ = run_cli("data", "list")
    assert status == 0 and "hidden_effect" in text and "BSD-3-Clause" in text


def test_an_exported_record_reads_as_the_bundled_one(run_cli, tmp_path):
    status, out, _ = run_cli("data", "export", "insole_left_steps", tmp_path / "new")
    assert status == 0
    csv = tmp_path / "new" / "insole_left_steps.csv"
    assert f"written {csv}" in out
    exported, bundled = read_record(csv), data.insole_left_steps()
    np.testing.assert_array_equal(exported.signal, bundled.signal)
    assert exported.metadata == bundled.metadata
    licence = (tmp_path / "new" / "insole_left_steps.LICENSE").read_text()
    assert licence == data.path("real/insole/LICENSE").read_text()


def test_a_network_record_comes_with_the_design_it_names(tmp_path):
    written = data.export("built_network", tmp_path)
    assert [p.name for p in written] == ["built_network.csv", "built_network.design.json"]
    record = read_record(written[0])
    assert record.design_path() == written[1]


def test_an_existing_file_is_replaced_only_with_force(run_cli, tmp_path):
    target = tmp_path / "hidden_effect.csv"
    target.write_text("mine\n")
    status, _, err = run_cli("data", "export", "hidden_effect", tmp_path)
    assert status == 2 and "exists already" in err and "--force" in err
    assert target.read_text() == "mine\n"
    status, _, _ = run_cli("data", "export", "hidden_effect", tmp_path, "--force")
    assert status == 0 and target.read_bytes() == data.path("hidden_effect.csv").read_bytes()


@pytest.mark.parametrize("args, message", [
    (("data", "export", "nope"), "no bundled record 'nope'; bundled: hidden_effect, built_network"),
    (("data", "export"), "give the NAME of a record"),
    (("data", "lst"), "data 'lst': use list or export"),
    (("data", "list", "hidden_effect"), "data list takes no NAME"),
])
def test_wrong_use_is_one_line(run_cli, args, message):
    status, out, err = run_cli(*args)
    assert status == 2 and message in err and out == ""


def test_a_file_where_the_folder_should_be_is_refused(tmp_path):
    (tmp_path / "f").write_text("")
    with pytest.raises(InputError, match="is a file, not a folder"):
        data.export("hidden_effect", tmp_path / "f")
