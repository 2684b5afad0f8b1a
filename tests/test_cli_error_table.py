"""Every subcommand of `avionics` and `sitl`, given bad values and missing files, fails in one line with the README's
exit code ("Exit codes": 2 configuration, scenario, file or usage error; 1 a link or zenoh session that cannot be
opened), never with a traceback.

The subcommands are enumerated from the real argparse parsers: a new subcommand without a row here fails
test_every_subcommand_has_rows. Each case is the real command line in a child process (`python -m`, this checkout
on PYTHONPATH). Cases that end before anything is opened (usage errors, `config` validation) run together in one
child per program, each through the program's main() with its own stderr; the others run one child each, a few at a
time. No sleeps, no timing asserts.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import socket
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pytest

pytestmark = pytest.mark.live  # child processes, one zenoh client session on loopback

ROOT = Path(__file__).resolve().parent.parent
TIMEOUT_S = 120.0
MODULES = {"avionics": "avionics_eval.cli", "sitl": "avionics_sitl.cli"}  # the console scripts (pyproject.toml)
LOG_LINE = re.compile(r"^\d{4}-\d\d-\d\d \d\d:\d\d:\d\d,\d{3} ")  # logging's lines (avionics.cli.main), not errors


def subcommands(program: str) -> set[str]:
    import importlib

    parser = importlib.import_module(MODULES[program]).build_parser()
    actions = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
    return {name for a in actions for name in a.choices}


def free_tcp_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.fixture(scope="module")
def files(tmp_path_factory) -> dict[str, str]:
    """Bad inputs on disk: paths that do not exist, an empty log, non-UTF-8 and mutated TOML, an extreme table."""
    d = tmp_path_factory.mktemp("bad-inputs")
    (d / "empty.tlog").write_bytes(b"")
    (d / "latin1.toml").write_bytes("[vehicle]\nid = \"caf\xe9\"\n".encode("latin-1"))
    (d / "huge-int.toml").write_text(f"[conflict]\nseed = {'9' * 5000}\n")
    profile = (ROOT / "config" / "profiles" / "small-uas.toml").read_text()
    (d / "sl-x.toml").write_text(profile.replace("sl = 1", 'sl = "x"'))
    (d / "sl-table.toml").write_text(profile.replace("sl = 1", "sl = {a = 1}"))
    (d / "sl-inf.toml").write_text(profile.replace("sl = 1", "sl = -inf"))
    rows = (ROOT / "tests" / "data" / "opensky_cdg_crossing.csv").read_text().splitlines()
    fields = rows[5].split(",")
    fields[6] = "1e300"  # groundspeed: finite, far beyond any aircraft
    (d / "extreme.csv").write_text("\n".join(rows[:5] + [",".join(fields)] + rows[6:]) + "\n")
    (d / "results").mkdir()
    return {"dir": str(d), "missing": str(d / "no-such"), **{p.stem + p.suffix.replace(".", "_"): str(p)
                                                             for p in d.iterdir()}}


# (argv, exit code, a word the line must hold). `{name}` is a path of `files`; `{port}` a free TCP port.
# In one child per program: nothing is opened before the error.
DRY = {
    "avionics": {
        "run": [(["run", "--duration", "nan"], 2, "--duration"), (["run", "--traffic", "bogus:x"], 2, "bogus")],
        "demo": [(["demo", "--port", "0"], 2, "--port"), (["demo", "--noise", "loud"], 2, "--noise")],
        "bench": [(["bench", "--intruders", "ten"], 2, "--intruders"), (["bench", "--seconds", "-1"], 2, "--seconds"),
                  (["bench", "--soak", "inf"], 2, "--soak"), (["bench", "--max-trials", "x"], 2, "--max-trials")],
        "evaluate": [(["evaluate", "--encounters", "many"], 2, "--encounters"),
                     (["evaluate", "--encounters", "10"], 2, "--out is required"),
                     (["evaluate", "--out", "{missing}/results"], 2, "no such directory"),
                     (["evaluate", "--report", "{missing}"], 2, "no such results directory"),
                     (["evaluate", "--report", "{results}", "--plots", "{missing}/plots"], 2, "no such directory")],
        "warmup": [(["warmup", "--bogus"], 2, "unrecognized arguments")],
        "config": [(["config", "--config", "{missing}"], 2, "No such file"),
                   (["config", "--config", "{latin1_toml}"], 2, "not UTF-8"),
                   (["config", "--config", "{huge-int_toml}"], 2, "4300"),
                   (["config", "--set", "conflict.step_s=1e-320"], 2, "conflict.step_s"),
                   (["config", "--set", "advisory.assessment_hz=1e-320"], 2, "advisory.assessment_hz"),
                   (["config", "--set", f"conflict.seed={'9' * 30}"], 2, "conflict.seed"),
                   (["config", "--set", "advisory.profile={sl-x_toml}"], 2, "sl"),
                   (["config", "--set", "advisory.profile={sl-table_toml}"], 2, "sl"),
                   (["config", "--set", "advisory.profile={sl-inf_toml}"], 2, "sl"),
                   (["config", "--set", "advisory.profile=nope"], 2, "unknown profile"),
                   (["config", "--set", "nonsense"], 2, "section.key=value")],
        "monitor": [(["monitor", "--duration", "-1"], 2, "--duration"), (["monitor", "--mode", "router"], 2, "--mode")],
        "router": [(["router", "--listen", "foo"], 2, "'foo'")],
    },
    "sitl": {
        "list": [(["list", "--bogus"], 2, "unrecognized arguments")],
        "replay": [(["replay"], 2, "encounter"), (["replay", "head-on", "--gap", "0"], 2, "--gap"),
                   (["replay", "head-on", "--seed", "x"], 2, "--seed"),
                   (["replay", "head-on", "--out", "{missing}/a.csv"], 2, "no such directory"),
                   (["replay", "head-on", "--set", "conflict.step_s=1e-320"], 2, "conflict.step_s"),
                   (["replay", "no-such"], 2, "'no-such'"), (["replay", "{missing}.daa"], 2, "no-such")],
        "live": [(["live", "head-on", "--duration", "nan"], 2, "--duration"),
                 (["live", "head-on", "--sbs", ":70000"], 2, "--sbs"),
                 (["live", "head-on", "--no-adsb-vehicle"], 2, "--no-adsb-vehicle")],
    },
}
# One child each: these open (or try to open) a file, a link or a session before they fail.
OPENING = {
    "avionics": {
        "run": [(["run", "--no-zenoh", "--connection", "{missing}.tlog"], 2, "no such file"),
                (["run", "--no-zenoh", "--connection", "{empty_tlog}"], 2, "read 0 MAVLink messages"),
                (["run", "--no-zenoh", "--connection", "udpin:127.0.0.1:0"], 1, "UDP port 0"),
                (["run", "--no-zenoh", "--connection", "udpin:127.0.0.1:{port}", "--csv", "{missing}/a.csv"], 2,
                 "no such directory"),
                (["run", "--connection", "udpin:127.0.0.1:{port}", "--set", 'zenoh.mode="client"', "--set",
                  'zenoh.connect=["tcp/127.0.0.1:{port}"]', "--set", "zenoh.listen=[]"], 1,
                 "cannot open zenoh session")],
        "demo": [(["demo", "--profile", "nope"], 2, "unknown profile"),
                 (["demo", "--scenario", "{missing}.daa"], 2, "No such file")],
    },
    "sitl": {
        "replay": [(["replay", "{extreme_csv}", "--ownship", "3944e7"], 2, "row 5")],
        "live": [(["live", "head-on", "--connection", "bogus:foo", "--duration", "5"], 1, "cannot open MAVLink")],
    },
}


def _expand(argv: list[str], files: dict[str, str], port: int) -> list[str]:
    out = []
    for a in argv:
        a = a.replace("{port}", str(port))
        for key, value in files.items():
            a = a.replace("{" + key + "}", value)
        out.append(a)
    return out


def _env() -> dict[str, str]:
    return {**os.environ, "PYTHONPATH": str(ROOT)}


# The driver of the dry cases: each argv through the program's real main(), its stderr captured alone.
DRIVER = """
import contextlib, io, json, sys
main = __import__(sys.argv[1], fromlist=["main"]).main
results = []
for argv in json.loads(sys.stdin.read()):
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        try:
            code = main(argv)
        except SystemExit as exc:
            code = exc.code
    results.append({"code": code, "stderr": err.getvalue()})
print(json.dumps(results))
"""


def _check(program: str, argv: list[str], code: int, needle: str, got_code, stderr: str) -> None:
    what = f"{program} {' '.join(argv)}"
    assert "Traceback" not in stderr, f"{what}:\n{stderr}"
    assert got_code == code, f"{what}: exit {got_code}, expected {code}:\n{stderr}"
    errors = [line for line in stderr.splitlines() if line.startswith(f"{program}: ")]
    others = [line for line in stderr.splitlines() if not line.startswith(f"{program}: ") and not LOG_LINE.match(line)]
    assert len(errors) == 1 and not others, f"{what}: expected one line `{program}: ...`:\n{stderr}"
    assert needle in errors[0], f"{what}: {needle!r} not in {errors[0]!r}"
    assert ".rs:" not in errors[0], f"{what}: a Rust source path in {errors[0]!r}"


def test_every_subcommand_has_rows():
    for program in MODULES:
        covered = set(DRY[program]) | set(OPENING.get(program, {}))
        assert subcommands(program) <= covered, f"{program}: no error cases for {subcommands(program) - covered}"
        assert all(DRY[program].get(name) for name in subcommands(program)), \
            f"{program}: every subcommand needs at least one bad value"


@pytest.mark.parametrize("program", sorted(MODULES))
def test_dry_errors_in_one_child(program, files):
    cases = [(argv, code, needle) for rows in DRY[program].values() for argv, code, needle in rows]
    argvs = [_expand(argv, files, 0) for argv, _, _ in cases]
    proc = subprocess.run([sys.executable, "-c", DRIVER, MODULES[program]], input=json.dumps(argvs),
                          capture_output=True, text=True, timeout=TIMEOUT_S, cwd=ROOT, env=_env())
    assert proc.returncode == 0, proc.stderr
    results = json.loads(proc.stdout.splitlines()[-1])
    for (argv, code, needle), result in zip(cases, results):
        _check(program, argv, code, needle, result["code"], result["stderr"])


def test_errors_after_opening_each_in_its_own_child(files):
    port = free_tcp_port()  # nothing listens there: a zenoh client cannot connect, a UDP port is free
    cases = [(program, argv, code, needle) for program, table in OPENING.items() for rows in table.values()
             for argv, code, needle in rows]

    def one(case):
        program, argv, _, _ = case
        return subprocess.run([sys.executable, "-m", MODULES[program], *_expand(argv, files, port)],
                              capture_output=True, text=True, timeout=TIMEOUT_S, cwd=ROOT, env=_env(),
                              stdin=subprocess.DEVNULL)

    with ThreadPoolExecutor(max_workers=3) as pool:
        procs = list(pool.map(one, cases))
    for (program, argv, code, needle), proc in zip(cases, procs):
        _check(program, argv, code, needle, proc.returncode, proc.stderr)


def test_a_serial_device_without_pyserial_names_the_extra(tmp_path):
    """A flight install without the [serial] extra: pyserial is made unimportable in the child (None in
    sys.modules is how Python marks a module that must not be imported), as on a machine without it."""
    code = ("import sys; sys.modules['serial'] = None; from avionics.cli import main; "
            "sys.exit(main(['run', '--no-zenoh', '--connection', '/dev/ttyDAA-no-such-port']))")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=TIMEOUT_S,
                          cwd=ROOT, env=_env())
    _check("avionics", ["run", "serial"], 1, "pip install '.[serial]'", proc.returncode, proc.stderr)
    assert "pyserial" in proc.stderr
