"""Hostile input at the input/output edges: special files as inputs and outputs, a gzip bomb,
unsafe unit names and cells in a fleet, a fleet folder in use or holding other settings, and
SIGTERM handled as Ctrl-C."""

import gzip
import json
import os
import signal
import stat
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pytest

from creepcomp.errors import InputError
from creepcomp.io import inputs
from creepcomp.io.atomic import write_text_atomic
from creepcomp.io.formats import read_any
from creepcomp.io.jsonfiles import read_design, read_json, read_model
from creepcomp.io.outputs import check_output_file
from creepcomp.io.records import read_record

DATA = Path(__file__).resolve().parents[1] / "src" / "creepcomp" / "data"
MODEL = DATA / "default_sensor.json"
DESIGN = DATA / "built_network.design.json"
RECORD = DATA / "hidden_effect.csv"


@pytest.fixture
def no_hang():
    """Fail (instead of blocking the suite) when the test is still running after 20 s: the
    alarm interrupts a blocking open of a named pipe."""
    def expired(signum, frame):
        raise TimeoutError("blocked: a special file was opened")

    previous = signal.signal(signal.SIGALRM, expired)
    signal.alarm(20)
    yield
    signal.alarm(0)
    signal.signal(signal.SIGALRM, previous)


@pytest.fixture
def fifo(tmp_path):
    path = tmp_path / "fifo"
    os.mkfifo(path)
    return path


def one_line_error(status, err, needle):
    assert status == 2, err
    assert needle in err, err
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err


def test_special_files_as_inputs_are_refused_before_they_are_opened(no_hang, fifo, tmp_path,
                                                                   run_cli):
    folder = tmp_path / "folder"
    folder.mkdir()
    for read in (read_record, read_any, read_model, read_design, read_json):
        with pytest.raises(InputError, match="named pipe"):
            read(fifo)
        with pytest.raises(InputError, match="a folder, not a regular file"):
            read(folder)
    for read in (read_record, read_model):
        with pytest.raises(InputError, match="character device"):
            read("/dev/zero")
    one_line_error(*run_cli("fit", fifo)[::2], "named pipe")
    one_line_error(*run_cli("size", "--model", fifo)[::2], "named pipe")
    # a record's '# design:' line naming a pipe
    record = tmp_path / "built.csv"
    record.write_text((DATA / "built_network.csv").read_text().replace(
        "# design: built_network.design.json", f"# design: {fifo.name}"))
    with pytest.raises(InputError, match="design file .*named pipe"):
        read_design(read_record(record).design_path())


def test_a_model_file_beyond_its_size_limit_is_refused_unread(tmp_path, monkeypatch):
    big = tmp_path / "big.json"
    big.write_text(json.dumps({"beta": [0.01] * 100, "tau": [1.0] * 100}))
    monkeypatch.setattr(inputs, "MAX_JSON_BYTES", 1000)
    monkeypatch.setattr("creepcomp.io.jsonfiles.MAX_JSON_BYTES", 1000)
    with pytest.raises(InputError, match="more than the 1000 bytes a model file may have"):
        read_model(big)


def test_deeply_nested_json_is_one_error(tmp_path):
    deep = tmp_path / "deep.json"
    deep.write_text("[" * 100_000 + "]" * 100_000)
    with pytest.raises(InputError, match="nested too deeply"):
        read_model(deep)


def _device(tmp_path, name, major, minor):
    """A private character device node (root only), so that a failure replaces no system file."""
    path = tmp_path / name
    try:
        os.mknod(path, stat.S_IFCHR | 0o666, os.makedev(major, minor))
    except PermissionError:
        pytest.skip("making a device node needs root")
    return path


def test_outputs_never_replace_special_files(no_hang, fifo, tmp_path, run_cli):
    full = _device(tmp_path, "full", 1, 7)
    to_fifo = tmp_path / "to-fifo"
    to_fifo.symlink_to(fifo)
    to_folder = tmp_path / "to-folder"
    to_folder.symlink_to(tmp_path)
    for target, what in ((fifo, "named pipe"), (full, "character device"),
                         (to_fifo, "symbolic link"), (to_folder, "is a folder")):
        one_line_error(*run_cli("size", "--model", MODEL, "-o", target)[::2], what)
    assert stat.S_ISFIFO(os.stat(fifo).st_mode) and stat.S_ISCHR(os.stat(full).st_mode)
    assert to_fifo.is_symlink() and to_folder.is_symlink()
    with pytest.raises(InputError, match="character device"):
        check_output_file("/dev/full")
    # the atomic writer itself refuses, for the writers no command checks first
    with pytest.raises(InputError, match="named pipe"):
        write_text_atomic(fifo, "x")
    assert stat.S_ISFIFO(os.stat(fifo).st_mode)
    assert not [p for p in tmp_path.iterdir() if p.name.endswith(".part")]


def test_a_link_to_a_regular_file_is_replaced_and_its_target_kept(tmp_path, run_cli):
    target = tmp_path / "target.json"
    target.write_text("kept")
    link = tmp_path / "link.json"
    link.symlink_to(target)
    status, _, err = run_cli("size", "--model", MODEL, "-o", link)
    assert status == 0, err
    assert not link.is_symlink() and "creep" in json.loads(link.read_text())
    assert target.read_text() == "kept"


def test_unknown_plot_ending_and_firmware_folder_refused_before_the_work(tmp_path, run_cli):
    one_line_error(*run_cli("size", "--model", MODEL, "-o", tmp_path / "d.json",
                            "--plot", tmp_path / "x.xyz")[::2], "unknown file ending '.xyz'")
    folder = tmp_path / "fw"
    folder.mkdir()
    os.mkfifo(folder / "creep.c")
    one_line_error(*run_cli("firmware", MODEL, "--rate", "100", "--full-scale", "1",
                            "-o", folder)[::2], "named pipe")
    afile = tmp_path / "afile"
    afile.write_text("x")
    one_line_error(*run_cli("firmware", MODEL, "--rate", "100", "--full-scale", "1",
                            "-o", afile)[::2], "not a folder")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["afile", "fw"]
    assert [p.name for p in folder.iterdir()] == ["creep.c"]


def test_a_gzip_bomb_is_refused_at_its_bound_without_growing(tmp_path, monkeypatch):
    import tracemalloc

    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    bomb = tmp_path / "bomb.csv.gz"
    with gzip.open(bomb, "wb", compresslevel=6) as fh:
        fh.write(b"time,load,signal\n")
        block = b"0,1,1\n" * (1 << 16)
        for _ in range(inputs.MIN_GZIP_BYTES // len(block) + 2):
            fh.write(block)
    assert bomb.stat().st_size < 1 << 20
    tracemalloc.start()
    try:
        with pytest.raises(InputError, match=r"expands to more than 64 MiB, the limit"):
            read_any(bomb)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 16 << 20, f"{peak / 2**20:.0f} MiB"
    assert not list(tmp_path.glob("creepcomp-*"))  # the decompressed copy is removed
    # a valid .gz reads as the CSV does
    good = tmp_path / "rec.csv.gz"
    good.write_bytes(gzip.compress(RECORD.read_bytes()))
    a, b = read_any(good), read_record(RECORD)
    assert (a.signal == b.signal).all() and a.metadata == b.metadata and a.source == str(good)
    (tmp_path / "bad.gz").write_bytes(b"not gzip")
    with pytest.raises(InputError, match="cannot decompress it"):
        read_any(tmp_path / "bad.gz")


def test_unit_names_are_safe_and_unique():
    from creepcomp.fleet.discover import MAX_UNIT_NAME, unit_names

    root = Path("/r")
    names = unit_names([root / "...csv", root / "S 1.csv", root / "S_1.csv", root / "s_1.csv",
                        root / ".hidden.csv", root / "-rf.csv", root / "a\x01\nb.csv",
                        root / '=HYPERLINK("http:__x","c").csv', root / ("x" * 300 + ".csv")])
    assert names[:7] == ["__", "S_1", "S_1~2", "s_1~3", "_hidden", "_rf", "a__b"]
    assert names[7] == "_HYPERLINK__http___x___c__"
    assert len(names[8]) == MAX_UNIT_NAME and "~" in names[8]
    assert len({n.lower() for n in names}) == len(names)
    assert all(n not in (".", "..") and not n.startswith((".", "-", "+", "=", "@")) for n in names)


def test_fleet_csv_cells_cannot_start_a_formula(tmp_path):
    import pyarrow.csv as pacsv

    from creepcomp.fleet.table import arrow_table, write_table
    from creepcomp.fleet.unit import empty_row

    rows = [empty_row("/r/S1.csv", "S1"), empty_row("/r/S2.csv", "S2")]
    rows[0].update(signal_unit='=HYPERLINK("http://x/?"&A1,"click")', offset=-1.5, status="ok")
    rows[1].update(signal_unit="@SUM(1)", notes="\tx", error="-2+3", offset=2.0, status="ok")
    table = arrow_table(rows)
    paths = write_table(table, tmp_path)
    back = pacsv.read_csv(paths["csv"]).to_pylist()
    assert back[0]["signal_unit"] == "'" + rows[0]["signal_unit"]
    assert back[1]["signal_unit"] == "'@SUM(1)" and back[1]["error"] == "'-2+3"
    assert back[1]["notes"] == "'\tx"
    assert [r["offset"] for r in back] == [-1.5, 2.0]  # numbers stay numbers
    import pyarrow.parquet as pq
    assert pq.read_table(paths["parquet"]).column("signal_unit")[0].as_py() == rows[0]["signal_unit"]


def test_fleet_folder_refuses_other_settings_and_a_second_run(tmp_path):
    from creepcomp.fleet import SERIAL, run
    from creepcomp.fleet.batch import SETTINGS_FILE, claim_folder, folder_lock
    from creepcomp.fleet.unit import run_settings

    out = tmp_path / "out"
    out.mkdir()
    first = run_settings(0.000245, False, False)
    claim_folder(out, first)
    claim_folder(out, first)  # the same settings: resume
    assert json.loads((out / SETTINGS_FILE).read_text())["settings"] == first
    with pytest.raises(InputError, match=r"other settings \(correct False there, True now\)"):
        claim_folder(out, run_settings(0.000245, True, False))
    record = tmp_path / "S1.csv"
    record.write_bytes(RECORD.read_bytes())
    with folder_lock(out):
        assert (out / ".fleet.lock").read_text().strip() == str(os.getpid())
        with pytest.raises(InputError, match="another fleet run"):
            run([record], out, scheduler=SERIAL)
    assert not (out / ".fleet.lock").exists()
    with pytest.raises(InputError, match="other settings"):
        run([record], out, scheduler=SERIAL, correct=True)
    assert not (out / "units" / "S1").exists()


def test_sigterm_stops_a_command_as_ctrl_c_does_and_leaves_nothing(tmp_path, monkeypatch,
                                                                   run_cli):
    import creepcomp.io.jsonfiles as jsonfiles

    real = jsonfiles.to_json

    def terminated_while_writing(obj):
        os.kill(os.getpid(), signal.SIGTERM)
        return real(obj)

    monkeypatch.setattr(jsonfiles, "to_json", terminated_while_writing)
    before = signal.getsignal(signal.SIGTERM)
    status, _, err = run_cli("size", "--model", MODEL, "-o", tmp_path / "d.json")
    assert status == 143 and err.strip() == "creepcomp: error: terminated"
    assert list(tmp_path.iterdir()) == []
    assert signal.getsignal(signal.SIGTERM) == before


def test_a_signal_held_while_a_step_runs_is_taken_at_its_end():
    from creepcomp.interrupts import interrupts_held

    class Stopped(Exception):
        pass

    def stop(signum, frame):
        raise Stopped

    previous = signal.signal(signal.SIGTERM, stop)
    steps = []
    try:
        with pytest.raises(Stopped):
            with interrupts_held():
                os.kill(os.getpid(), signal.SIGTERM)
                steps.append("after the signal")
            steps.append("after the block")
        assert steps == ["after the signal"] and signal.getsignal(signal.SIGTERM) is stop
    finally:
        signal.signal(signal.SIGTERM, previous)


class _HalfMade:
    """An object whose ``__del__`` fails, as a library's does when an interrupt cuts its
    constructor short."""

    def __del__(self):
        raise AttributeError("'_HalfMade' object has no attribute '_owned'")


@pytest.mark.parametrize("signum, status, line", [(signal.SIGTERM, 143, "terminated"),
                                                  (signal.SIGINT, 130, "interrupted")])
def test_a_stop_reports_one_line_even_when_an_object_cut_short_fails_in_its_del(
        signum, status, line, tmp_path, monkeypatch, run_cli):
    import creepcomp.io.jsonfiles as jsonfiles

    real = jsonfiles.to_json
    reported = []
    monkeypatch.setattr(sys, "unraisablehook", reported.append)

    def stopped_while_building(obj):
        half_made = _HalfMade()  # noqa: F841 (freed as the interrupt unwinds this frame)
        os.kill(os.getpid(), signum)
        return real(obj)

    monkeypatch.setattr(jsonfiles, "to_json", stopped_while_building)
    # Ctrl-C as on a terminal (a shell starts a background job with it ignored)
    before = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        code, _, err = run_cli("size", "--model", MODEL, "-o", tmp_path / "d.json")
        assert signal.getsignal(signal.SIGINT) is signal.default_int_handler
    finally:
        signal.signal(signal.SIGINT, before)
    assert code == status and err.strip() == f"creepcomp: error: {line}", err
    assert reported == []


def test_an_object_failing_in_its_del_is_reported_when_nothing_stops(tmp_path, monkeypatch,
                                                                     run_cli):
    import creepcomp.io.jsonfiles as jsonfiles

    real = jsonfiles.to_json
    reported = []
    monkeypatch.setattr(sys, "unraisablehook", reported.append)

    def with_a_failing_del(obj):
        _HalfMade()
        return real(obj)

    monkeypatch.setattr(jsonfiles, "to_json", with_a_failing_del)
    code, _, _ = run_cli("size", "--model", MODEL, "-o", tmp_path / "d.json")
    assert code == 0 and [type(u.exc_value) for u in reported] == [AttributeError]


def _group(pgid: int) -> list[int]:
    """Processes of the process group ``pgid`` (zombies excluded)."""
    found = []
    for entry in os.listdir("/proc"):
        if entry.isdigit():
            try:
                fields = Path(f"/proc/{entry}/stat").read_text().rsplit(")", 1)[1].split()
            except OSError:
                continue
            if int(fields[2]) == pgid and fields[0] != "Z":
                found.append(int(entry))
    return found


def _terminated_with_workers(args: list[str], whole_group: bool) -> tuple[int, str]:
    """Run ``creepcomp args`` in a process group of its own, send SIGTERM once a worker process
    has started (to the command, or to its whole group); returns the exit status and stderr,
    after checking that no process of the group is left."""
    env = dict(os.environ, OPENBLAS_NUM_THREADS="1",
               PYTHONPATH=str(Path(__file__).resolve().parents[1] / "src"))
    proc = subprocess.Popen([sys.executable, "-c", "from creepcomp.cli import run; run()", *args],
                            env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
                            start_new_session=True)
    try:
        deadline = time.monotonic() + 60
        while len(_group(proc.pid)) < 2 and time.monotonic() < deadline and proc.poll() is None:
            time.sleep(0.02)
        assert len(_group(proc.pid)) >= 2, "no worker process started"
        if whole_group:
            os.killpg(proc.pid, signal.SIGTERM)
        else:
            proc.send_signal(signal.SIGTERM)
        _, err = proc.communicate(timeout=60)
        deadline = time.monotonic() + 10
        while _group(proc.pid) and time.monotonic() < deadline:
            time.sleep(0.05)
        assert _group(proc.pid) == []
        return proc.returncode, err
    finally:
        for pid in _group(proc.pid):
            os.kill(pid, signal.SIGKILL)


@pytest.mark.skipif(not Path("/proc").is_dir(), reason="lists processes through /proc")
def test_sigterm_to_mc_stops_its_workers(tmp_path):
    """SIGTERM to a running ``mc`` with worker processes: exit 143, one line, no report, and no
    process of its group left running."""
    status, err = _terminated_with_workers(["mc", str(DESIGN), "--n", "5000000", "--report",
                                            str(tmp_path / "mc.html")], whole_group=False)
    assert status == 143 and err.strip().endswith("creepcomp: error: terminated"), err
    assert list(tmp_path.iterdir()) == []


@pytest.mark.skipif(not Path("/proc").is_dir(), reason="lists processes through /proc")
def test_sigterm_to_the_process_group_of_diagnose_is_one_line(tmp_path):
    """SIGTERM to the whole group of ``diagnose --jobs 2`` (as a service manager sends it): the
    worker processes leave it to the main one: exit 143, one line, no output, no process left."""
    out = tmp_path / "out"
    status, err = _terminated_with_workers(["diagnose", str(RECORD), "--jobs", "2", "-o", str(out)],
                                           whole_group=True)
    assert status == 143 and err.strip() == "creepcomp: error: terminated", err
    assert not out.exists()


@pytest.mark.skipif((os.cpu_count() or 1) < 2, reason="mc starts worker processes on 2 cores or more")
@pytest.mark.parametrize("when", ["a process started", "the pool's thread starting"])
def test_sigterm_while_mc_starts_its_workers_stops_them(when, tmp_path, monkeypatch, run_cli):
    """SIGTERM at either point where the pool starts (some processes forked and no thread yet to
    stop them; the thread started and not yet running): exit 143, the processes ended."""
    from concurrent.futures import process

    started = []
    spawn, start = process.ProcessPoolExecutor._spawn_process, process._ExecutorManagerThread.start

    def spawned(pool):
        spawn(pool)
        started.extend(pool._processes.values())
        if when == "a process started" and len(started) == 1:
            os.kill(os.getpid(), signal.SIGTERM)

    def starting(thread):
        if when == "the pool's thread starting":
            os.kill(os.getpid(), signal.SIGTERM)
        start(thread)

    monkeypatch.setattr(process.ProcessPoolExecutor, "_spawn_process", spawned)
    monkeypatch.setattr(process._ExecutorManagerThread, "start", starting)
    try:
        status, _, err = run_cli("mc", DESIGN, "--n", "200000", "--report", tmp_path / "mc.html")
        assert status == 143 and err.strip().endswith("creepcomp: error: terminated"), err
        assert started
        for worker in started:
            worker.join(10)
        assert not any(worker.is_alive() for worker in started)
        assert list(tmp_path.iterdir()) == []
    finally:
        for worker in started:
            if worker.is_alive():
                worker.kill()


def test_an_interrupted_firmware_verify_leaves_no_c_files(tmp_path, monkeypatch, run_cli):
    import creepcomp.digital.firmware_check as firmware_check

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(firmware_check, "verify_firmware", interrupted)
    record = tmp_path / "rec.csv"
    record.write_text("time,load,signal\n" + "".join(f"{i * 0.01:.2f},1,{1 + i * 1e-6}\n"
                                                      for i in range(200)))
    status, _, err = run_cli("firmware", MODEL, "--verify", record, "-o", tmp_path / "fw")
    assert status == 130 and "interrupted" in err
    assert not (tmp_path / "fw").exists()


@pytest.mark.slow
def test_a_fleet_on_a_local_cluster_leaves_no_scratch_folder(tmp_path, monkeypatch):
    from creepcomp.fleet import run

    scratch = tmp_path / "tmp"
    scratch.mkdir()
    monkeypatch.setenv("TMPDIR", str(scratch))
    monkeypatch.setattr(tempfile, "tempdir", None)
    record = tmp_path / "S1.csv"
    record.write_bytes(RECORD.read_bytes())
    result = run([record], tmp_path / "out", workers=1)
    assert result.to_dict()["ok"] == 1
    assert list(scratch.iterdir()) == []


@pytest.mark.filterwarnings("ignore::pytest.PytestUnraisableExceptionWarning")
def test_a_sigterm_whose_exception_is_lost_is_delivered_again():
    """A SIGTERM that arrives where Python ignores exceptions (an at-fork hook, a __del__)
    must still stop the command: it is delivered again until taken."""
    import creepcomp.cli as cli

    class Swallows:
        def __del__(self):
            cli._raise_terminated(signal.SIGTERM, None)

    previous = signal.signal(signal.SIGTERM, cli._raise_terminated)
    try:
        with pytest.raises(cli.Terminated):
            Swallows()          # its __del__ raises, and Python ignores that exception
            time.sleep(5)       # the second delivery stops this
    finally:
        cli._cancel_redelivery()
        signal.signal(signal.SIGTERM, previous)


def test_a_second_signal_does_not_cut_the_pools_shutdown_short():
    """SIGTERM is delivered again while ``mc`` stops: the pool's shutdown is waited for to its
    end, not left half done (which made the interpreter's exit wait for the pool)."""
    from creepcomp.verify.montecarlo import _shut_down

    class Pool:
        calls = 0
        done = False

        def shutdown(self, wait, cancel_futures):
            Pool.calls += 1
            if Pool.calls < 3:
                raise KeyboardInterrupt
            Pool.done = True

    _shut_down(Pool())
    assert Pool.calls == 3 and Pool.done
