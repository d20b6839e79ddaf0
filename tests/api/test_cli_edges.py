"""Every ``rig`` command, fed what a user can type wrong (malformed ids, ambiguous
prefixes, missing files, unreachable ports): one ``error: …`` line on stderr, exit 2 (1 when
a device or the run failed), never a traceback.

Cases that reach a device, a port or the data folder run as real subprocesses; the others
(bad ids, files and values: refused before anything opens) run in this process, answered
as a fresh process would answer (tests/support/cli.py ``run_in_process``): one interpreter start per
case cost about 0.5 s of CPU (2 s importing SciPy)."""

from __future__ import annotations

import importlib
import importlib.util
import json
import os
import re
import socket
import subprocess
import sys
from pathlib import Path

import click
import pytest

from api.cli.command_table import PROCEDURES_MODULE, kind_commands, short_helps
from api.cli.main import COMMANDS, DEBUG_ENV, main
from daq.procedures.run_kinds import RIG_KINDS
from daq.store import Store
from tests.store.helpers import new_run
from tests.support.cli import run_in_process

ROOT = Path(__file__).resolve().parents[2]
BENBAM = ROOT / "fixtures" / "rigs" / "benbam.toml"
RIG = "rig.toml"  # a copy of BENBAM's in the test's folder (relative: no paths in messages)
HUGE = "9" * 23  # no 64-bit id is this large
#: A case per command at least: (argv, exit status, text the error line must hold).
CASES: list[tuple[list[str], int, str]] = []


def case(code: int, expect: str, *argv: str) -> None:
    CASES.append((list(argv), code, expect))


# -- stored runs: ids ------------------------------------------------------------------
case(2, "no run with id 'zzz': a run id is a uuid", "show", "zzz")
case(2, "no run with id '" + "a" * 40 + "…'", "show", "a" * 100)
case(2, "no run with id '00000000'", "show", "00000000")
for cmd in ("show", "export", "estimate"):
    case(2, "matches several runs", cmd, "{ambiguous}")
case(2, "no run with id 'zzz'", "export", "zzz")
case(2, "no run with id 'zzz'", "annotate", "zzz", "--notes", "x")
case(2, "--meta: 'novalue' is not allowed; use KEY=VALUE", "annotate", "{run}", "--meta", "novalue")
case(2, "nothing to change: give --operator, --water-temp, --salinity, --notes, --tag, --meta, "
     "--untag or --unset", "annotate", "{run}")  # fmt: skip
case(2, "'--water-temp': 80.0 is not in the range -2.0<=x<=50.0", "tow", "--force", "10",
     "--water-temp", "80")  # fmt: skip
case(2, "--since: '23/11' is not allowed", "runs", "--since", "23/11")
case(2, "no run with id 'zzz'", "results", "--run", "zzz")
case(2, f"no result with id {HUGE}", "results", "--compare", HUGE, "1")
case(2, "no run with id 'zzz'", "estimate", "{run}", "zzz")
case(2, "no run with id 'zzz'", "crosscheck", "--weight", "zzz", "--thrusters", "{run}")
case(2, "matches several runs", "crosscheck", "--weight", "{ambiguous}", "--thrusters", "{run}")
case(
    2,
    f"'--weight-result': {HUGE} is not in the range",
    "crosscheck",
    "--weight-result",
    HUGE,
    "--thruster-result",
    "1",
)
case(  # refused as POST /api/sixdof/simulate refuses it: ids are at most 2^62
    2, f"--estimate[0]: {HUGE} is not allowed", "sixdof", "benbam", "--commands", "0.5,0.5",
    "--estimate", HUGE,
)  # fmt: skip
case(  # refused as POST /api/analysis/sensitivity refuses it: ids are at most 2^62
    2, f"--estimate[0]: {HUGE} is not allowed", "sensitivity", "benbam", "--estimate", HUGE
)
case(
    2,
    "'--commands': got 'a,b'; allowed: the form U1,U2,...",
    "sixdof",
    "benbam",
    "--commands",
    "a,b",
)
case(2, "no vehicle named 'nope'", "sixdof", "nope", "--commands", "0.5,0.5")
case(2, "no vehicle named 'nope'", "sensitivity", "nope")
case(2, "no vehicle named 'nope'", "predict-added-mass", "nope")
SEED_SEQUENCE = str(ROOT / "fixtures" / "sequences" / "seed000-campaign.toml")
case(2, "file: 'nope.toml' is not allowed (a readable sequence file", "predict-uncertainty",
     "nope.toml")  # fmt: skip
case(2, "'--release-std': -1.0 is not in the range 0<=x<=1", "predict-uncertainty", SEED_SEQUENCE,
     "--release-std", "-1")  # fmt: skip
case(2, f"--result[0]: {HUGE} is not allowed", "predict-uncertainty", SEED_SEQUENCE, "--result",
     HUGE)  # fmt: skip
case(2, f"no result with id {HUGE}", "predict-added-mass", "benbam", "--estimate", HUGE)
case(2, ": hull: got None, allowed: a [hull] table", "predict-added-mass", "seed002-rov")
case(2, "'--water-temp': 80.0 is not in the range 0.0<=x<=40.0", "predict-added-mass", "benbam",
     "--water-temp", "80")  # fmt: skip
case(2, "--tank-width/--water-depth: got one of the two", "predict-added-mass", "benbam",
     "--tank-width", "2")  # fmt: skip
case(2, "'--temp': -3.0 is not in the range 0.0<=x<=40.0", "water", "--temp", "-3")
case(2, "--speed/--length: got one of the two", "water", "--temp", "15", "--speed", "1")
case(2, "'--salinity': 50.0 is not in the range 0.0<=x<=42.0", "water", "--temp", "15",
     "--salinity", "50")  # fmt: skip
# -- files -------------------------------------------------------------------------------
case(2, "File 'nope.csv' does not exist", "import", "nope.csv", "--kind", "tow", "--force", "1")
case(2, "no header with a 't' column", "import", RIG, "--kind", "tow", "--force", "1")
case(2, "--force: missing is not allowed", "import", "{csv}", "--kind", "tow")
case(2, "--force: 1e+308 is not allowed (allowed 0 < |--force| ≤ 1e+06 N, a physical bound "
     "without a rig file", "import", "{csv}", "--kind", "tow", "--force", "1e308")  # fmt: skip
case(2, "--force: 1e+308 is not allowed (allowed 0 < |--force| ≤ 100 N, rig limit max_force_n",
     "import", "{csv}", "--kind", "tow", "--force", "1e308", "--rig", RIG)  # fmt: skip
case(2, "--torque: -1e+300 is not allowed (allowed 0 < |--torque| ≤ 1e+06 N·m, a physical "
     "bound", "import", "{csv}", "--kind", "spin", "--torque", "-1e300")  # fmt: skip
case(2, "--weight: 1e+200 is not allowed (allowed 0 < --weight ≤ 100000 kg, a physical bound",
     "import", "{csv}", "--kind", "tow", "--force", "5", "--weight", "1e200")  # fmt: skip
case(2, "--dry-mass: 1e+300 is not allowed (allowed 0 < --dry-mass ≤ 100000 kg, a physical "
     "bound", "import", "{csv}", "--kind", "tow", "--force", "5",
     "--dry-mass", "1e300")  # fmt: skip
case(2, "--output: cannot use /etc/passwd/x.csv", "export", "{run}", "-o", "/etc/passwd/x.csv")
case(
    2, "--output: cannot use /etc/passwd/x.nc", "export", "{run}", "--format", "netcdf",
    "-o", "/etc/passwd/x.nc",
)  # fmt: skip
case(2, "--report: cannot use /etc/passwd/r", "estimate", "{run}", "--report", "/etc/passwd/r")
case(2, "FILE: 'nope.toml' is not allowed", "sequence", "nope.toml")
case(
    2, "--target: 0.0 is not allowed (Input should be greater than 0)", "campaign", "--target", "0%"
)
case(2, "'--target': got 'abc'; allowed: the form N%", "campaign", "--target", "abc")
case(2, "--axis: ['yaw'] is not allowed (the rig cannot test yaw)", "campaign",
     "--axis", "yaw", "--rig", str(ROOT / "fixtures/rigs/encoder-tow.toml"))  # fmt: skip
case(2, "nope.toml: cannot read rig file", "tow", "--force", "10", "--rig", "nope.toml")
case(
    2, "nope.toml: cannot read scenario file", "spin", "--torque", "0.5", "--scenario", "nope.toml"
)
case(2, "nope.toml: cannot read rig file", "pendulum", "--angle", "0.2", "--rig", "nope.toml")
case(2, "nope.toml: cannot read rig file", "calibrate-thrusters", "--rig", "nope.toml")
case(
    2,
    "--command: 0.9 is not allowed (allowed -0.8 ≤ --command ≤ 0.8 (fraction of full thrust), "
    "rig limit max_thruster_command)",
    "manual-thrust", "--command", "0.9",
)  # fmt: skip
case(2, "--thruster: 3 is not allowed (allowed 1 ≤ --thruster ≤ 2", "manual-thrust",
     "--thruster", "3", "--command", "0.2")  # fmt: skip
case(2, "nope.toml: cannot read rig file", "sim", "--rig", "nope.toml")
case(2, "nope.toml: cannot read rig file", "serve", "--rig", "nope.toml")
case(2, "nope.toml: cannot read rig file", "capabilities", "--rig", "nope.toml")
case(2, "--ahp: ", "sensitivity", "benbam", "--ahp", RIG)
case(2, "cannot use /etc/passwd/towrig", "token", "{xdg:/etc/passwd}")
case(2, "Got unexpected extra argument (now)", "warm-up", "now")
# -- values: flags, not API field names --------------------------------------------------
case(2, "--force: 0.0 is not allowed (allowed 0 < |--force| ≤", "tow", "--force", "0")
case(2, "--weight: 0.0001 is not allowed", "tow", "--weight", "0.0001")
case(2, "--torque: 99.0 is not allowed", "spin", "--torque", "99")
case(
    2,
    "--force: -101.0 is not allowed (allowed 0 < |--force| ≤ 100 N, rig limit max_force_n; "
    "negative for a reverse test); --max-time: -2.0 is not allowed",
    "tow",
    "--force",
    "-101",
    "--max-time",
    "-2",
)
case(2, "Invalid value for '--force': 'abc'", "tow", "--force", "abc")
case(
    2,
    "--thrust-column: no column 'Nope'; the table has",
    "import-calibration",
    "{csv}",
    "--thrust-column",
    "Nope",
)
case(
    2,
    "--full-scale: a command in volts needs",
    "import-calibration",
    "{csv}",
    "--command-unit",
    "volts",
)
case(
    2,
    "'--voltage': 0.0 is not in the range 0<x<=1000",
    "import-calibration",
    "{csv}",
    "--voltage",
    "0",
)
case(
    2,
    "run.csv: line 2, column 'position': got 0, allowed: a command within full reverse",
    "import-calibration",
    "{csv}",
    "--command-column",
    "position",
    "--command-unit",
    "pwm_us",
    "--thrust-column",
    "t",
    "--voltage",
    "12",
)
case(2, "'--command': 1.5 is not in the range -1<=x<=1", "thrust", "--command", "1.5")
case(2, "--command or --force: give exactly one", "thrust")
case(2, "no thrust calibration stored", "thrust", "--force", "10")
case(
    2,
    "--calibration: 'x:1' is not allowed (ID or run:ID, e.g. 3 or run:12)",
    "thrust",
    "--force",
    "1",
    "--calibration",
    "x:1",
)
case(2, "--db: cannot open the database", "calibrations", "--db", "{pg}")
case(2, "No such command 'nosuch'", "nosuch")
# -- unreachable ports -------------------------------------------------------------------
case(2, "--db: cannot open the database: connection failed", "runs", "--db", "{pg}")
case(2, "--db: cannot open the database", "show", "{run}", "--db", "{pg}")
case(2, "--db: cannot open the database: connection failed", "jobs", "--db", "{pg}")
case(2, "--db: cannot open the database: connection failed", "queue", "--db", "{pg}")
MISSING_DB = "sqlite:///{tmp}/missing/dir/x.db"  # its folder does not exist: never made
for argv in (["tow", "--force", "9.8"], ["runs"], ["serve", "--port", "0"]):
    case(2, "--db: the folder {tmp}/missing/dir of database x.db does not exist", *argv,
         "--db", MISSING_DB)  # fmt: skip
case(2, "'--state': 'sleeping' is not one of", "jobs", "--state", "sleeping")
case(2, "--modbus-port: cannot listen on 127.0.0.1:{busy}", "sim", "--modbus-port", "{busy}")
case(2, "--host/--port: cannot bind 127.0.0.1:{busy}", "serve", "--port", "{busy}", "--db", "{db}")
case(1, "cannot connect to PLC at tcp 127.0.0.1:{closed}", "tow", "--force", "9.8", "--rig", "{hw}")
# -- people and the safety log -----------------------------------------------------------
case(2, "NAME: 'b b' is not allowed (allowed 1-40 letters", "user", "add", "b b")
case(2, "NAME: 'default' is not allowed", "user", "add", "default", "--role", "operator")
case(2, "NAME: no user named 'nobody'", "user", "remove", "nobody")
case(2, "--db: cannot open the database", "user", "list", "--db", "{pg}")
case(2, "--user: no user named 'nobody'", "ack-estop", "--user", "nobody")
case(1, "no emergency stop to acknowledge", "ack-estop", "--user", "default")
case(2, "--reason: '' is not allowed (allowed 1-200", "hold", "--user", "default", "--reason", "")
case(1, "the rig is not held", "release", "--user", "default")


@pytest.fixture(scope="module")
def world(tmp_path_factory):
    """A database with 17 finished runs (two must share a first hex digit), a CSV, a
    hardware rig file whose PLC port is closed, a busy port and a closed one."""
    tmp = tmp_path_factory.mktemp("cli-edges")
    db = f"sqlite:///{tmp}/rig.db"
    with Store(db) as store:
        ids = [new_run(store) for _ in range(17)]
        for run_id in ids:
            store.finish_run(run_id, "completed")
    firsts = [r[0] for r in ids]
    csv = tmp / "run.csv"
    csv.write_text("t,position\n0,0\n0.1,0.01\n0.2,0.03\n", encoding="utf-8")
    busy = socket.socket()
    busy.bind(("127.0.0.1", 0))
    busy.listen()
    closed = socket.socket()
    closed.bind(("127.0.0.1", 0))  # bound, never listening: connections are refused
    text = BENBAM.read_text(encoding="utf-8")
    (tmp / RIG).write_text(text, encoding="utf-8")
    hw = tmp / "hw.toml"
    text = re.sub(r'(?m)^mode = "simulated"', 'mode = "hardware"', text)
    text = text.replace("port = 5020", f"port = {closed.getsockname()[1]}", 1)
    hw.write_text(text.replace('port = "sim"', f'port = "{tmp}/no-tty"', 1), encoding="utf-8")
    yield {
        "db": db,
        "tmp": tmp,
        "run": ids[0],
        "ambiguous": next(c for c in firsts if firsts.count(c) > 1),
        "csv": csv.name,
        "hw": hw.name,
        "busy": str(busy.getsockname()[1]),
        "closed": str(closed.getsockname()[1]),
        "pg": f"postgresql+psycopg://rig:secret@127.0.0.1:{closed.getsockname()[1]}/rig",
    }
    busy.close()
    closed.close()


def test_every_command_of_the_group_has_cases():
    names = main.list_commands(click.Context(main))
    assert set(names) == set(COMMANDS)
    covered = {argv[0] for argv, _, _ in CASES}
    assert set(names) <= covered, f"commands without edge cases: {set(names) - covered}"


def test_the_lazy_help_table_matches_each_command():
    """``rig --help`` lists each command's short help read from its source without
    importing the modules: it must be what each command says of itself."""
    shorts = short_helps()
    assert list(shorts) == list(COMMANDS)
    for name, (module, attr) in COMMANDS.items():
        command = getattr(importlib.import_module(module), attr)
        assert command.name == name
        assert shorts[name] == command.get_short_help_str(limit=80), name


def test_a_command_module_run_as_a_script_names_its_command_from_the_table():
    """``python -m api.cli.serve`` (how the tests and a service unit start the server) runs
    the module as ``__main__``, and each process multiprocessing spawns from it (a CSV
    upload's import) runs it again as ``__mp_main__``: ``@rig_command()`` still finds its
    name in the table (a rehearsal's server answered every upload with a 500)."""
    done = subprocess.run(
        [sys.executable, "-m", "api.cli.serve", "--help"], capture_output=True, text=True
    )
    assert done.returncode == 0, done.stderr
    assert done.stdout.startswith("Usage: python -m api.cli.serve [OPTIONS]")
    spawned = "import runpy; runpy.run_module('api.cli.serve', run_name='__mp_main__')"
    done = subprocess.run([sys.executable, "-c", spawned], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr


def test_the_help_lists_each_kind_the_registry_runs_in_its_order():
    """``rig --help`` reads the kinds' commands from their modules' source (the registry
    costs ~0.4 s of CPU to import): exactly the kinds the registry runs, in its order, each
    with its command's own short help."""
    listed = kind_commands()
    assert list(listed) == [str(spec.command) for spec in RIG_KINDS.values()]
    assert list(COMMANDS)[: len(listed)] == list(listed)
    for spec in RIG_KINDS.values():
        _, attr = listed[str(spec.command)]
        command = getattr(importlib.import_module(PROCEDURES_MODULE), attr)
        assert short_helps()[str(spec.command)] == command.get_short_help_str(limit=80)


def test_a_command_that_is_no_kind_reads_no_kind_module(request):
    """``rig runs`` looks its command up without parsing the kinds' modules (~5 ms)."""
    from api.cli import command_table

    command_table._kind_helps.cache_clear()
    request.addfinalizer(command_table._kind_helps.cache_clear)
    assert COMMANDS["runs"] == ("api.cli.runs", "runs")
    assert command_table._kind_helps.cache_info().misses == 0
    assert COMMANDS["tow"] == (PROCEDURES_MODULE, "tow")  # a kind's: read then
    assert command_table._kind_helps.cache_info().misses == 1


def test_a_kind_module_dropped_in_is_listed_without_an_edit_to_the_table(
    monkeypatch, tmp_path, request
):
    """A new kind is a module of daq/procedures/kinds: ``rig --help`` lists its command,
    at its rank, with no edit to the command table."""
    import shutil

    from api.cli import command_table

    folder = tmp_path / "kinds"
    shutil.copytree(Path(importlib.import_module("daq.procedures.kinds").__path__[0]), folder)
    (folder / "manual_kind.py").write_text(
        'SPEC = KindSpec(kind="manual", rank=35, command="drive-one",\n'
        '    help="Drive one thruster by hand for a while.", request=requests.ManualRequest)\n'
    )
    found = importlib.util.find_spec(command_table.KINDS_PACKAGE)
    assert found is not None
    monkeypatch.setattr(found, "submodule_search_locations", [str(folder)])
    monkeypatch.setattr(importlib.util, "find_spec", lambda name: found)
    command_table._kind_helps.cache_clear()  # read the kinds again, then as installed
    request.addfinalizer(command_table._kind_helps.cache_clear)
    listed = command_table.kind_commands()
    assert list(listed).index("drive-one") == list(listed).index("pendulum") + 1
    assert listed["drive-one"] == (PROCEDURES_MODULE, "drive_one")
    assert short_helps()["drive-one"] == "Drive one thruster by hand for a while."


#: Cases run as real subprocesses: they reach a device, bind or connect to a port, or
#: read the data folder's token (in process they could leave a thread or a handler behind).
SUBPROCESS_MARKS = ("{hw}", "{busy}", "{closed}", "{xdg:")
SUBPROCESS_COMMANDS = ("serve", "sim")


def _in_subprocess(argv: list[str]) -> bool:
    return argv[0] in SUBPROCESS_COMMANDS or any(m in a for a in argv for m in SUBPROCESS_MARKS)


#: A case run as a real subprocess is the real stack: the slow lane (README, Tests).
LANED = [
    pytest.param(*c, marks=pytest.mark.slow) if _in_subprocess(c[0]) else pytest.param(*c)
    for c in CASES
]


@pytest.mark.parametrize(("argv", "code", "expect"), LANED, ids=lambda v: None)
def test_bad_input_is_one_line_never_a_traceback(world, argv, code, expect):
    env = os.environ | {"RIG_DATABASE_URL": world["db"], "XDG_DATA_HOME": str(world["tmp"])}
    env.pop(DEBUG_ENV, None)
    args = []
    for a in argv:
        if a.startswith("{xdg:"):
            env["XDG_DATA_HOME"] = a[5:-1]
            continue
        args.append(a.format(**world))
    if _in_subprocess(argv):
        proc = subprocess.run(
            [sys.executable, "-m", "api.cli.main", *args],
            cwd=world["tmp"],
            env=env,
            capture_output=True,
            text=True,
            timeout=60,
            stdin=subprocess.DEVNULL,
        )
    else:
        proc = run_in_process(args, cwd=world["tmp"], env=env)
    returncode, out, err = proc.returncode, proc.stdout, proc.stderr
    assert "Traceback" not in err + out, err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), err
    assert expect.format(**world) in lines[0], err
    assert returncode == code, (returncode, err)
    for leak in ("sqlite:", "secret", "Store(", "site-packages", "/work/"):
        assert leak not in lines[0], err
    assert not (world["tmp"] / "missing").exists()  # a --db folder is never made


@pytest.mark.slow  # a `rig tow` subprocess on the simulated rig: the slow lane
def test_a_weight_driven_tow_states_the_rounding_and_leaves_the_thrusters_quiet(world):
    """The note comes before the run; the thruster line says nothing ('NAK disarmed' was
    the close zeroing a controller that was never armed); the run stores both loads."""
    proc = subprocess.run(
        [sys.executable, "-m", "api.cli.main", "tow", "--force", "10", "--max-time", "1",
         "--baseline", "0.3", "--db", world["db"], "--json"],
        cwd=world["tmp"], capture_output=True, text=True, timeout=120,
    )  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    assert proc.stderr.splitlines() == [
        "note: --force 10 N asked for; weights hang to the gram, so 1.020 kg is hung and "
        "the run applies 9.996 N"
    ]
    with Store(world["db"]) as store:
        run = store.get_run(json.loads(proc.stdout)["run_id"])
    assert run.parameters["requested"] == {"force_n": 10.0}
    assert run.parameters["force_n"] == pytest.approx(9.996)


def test_a_cli_tow_while_the_disk_is_full_is_refused_before_the_rig_opens(world):
    """Less free space than a run needs where it would be stored: exit 1 in one line naming
    the place (no host path), its free bytes and the threshold; no run is made."""
    env = os.environ | {"RIG_DATABASE_URL": world["db"], "XDG_DATA_HOME": str(world["tmp"])}
    env["RIG_MIN_FREE_BYTES"] = str(2**62)  # more than any disk has free
    with Store(world["db"]) as store:
        before = len(store.list_runs(limit=1000))
    proc = run_in_process(["tow", "--force", "9.8"], cwd=world["tmp"], env=env)
    assert proc.returncode == 1, proc.stderr
    (line,) = proc.stderr.strip().splitlines()
    assert line.startswith("error: storage full (SQLite rig.db): the folder of SQLite rig.db has ")
    assert line.endswith(f" bytes free, under the {2**62} bytes a run needs; free some space first")
    assert str(world["tmp"]) not in line
    with Store(world["db"]) as store:
        assert len(store.list_runs(limit=1000)) == before
