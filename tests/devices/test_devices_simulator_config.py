"""The stage simulator refuses an impossible configuration in one line before it starts
(CLI, ``python -m``, :class:`SimulatorProcess`), and no line on its ports ends it."""

from __future__ import annotations

import socket

import pytest

from camcmm.cli.main import main
from camcmm_plugins.devices.simulator import ConfigError, SimulatorProcess, ZaberSim, parse

BAD = [  # (argv, words the message must hold)
    (["--axes", "0"], ["--axes", "0"]),
    (["--axes", "10"], ["--axes", "10"]),
    (["--address", "0"], ["--address", "0"]),
    (["--address", "1000"], ["--address", "1000"]),
    (["--resolution", "0"], ["--resolution", "0"]),
    (["--resolution", "nan"], ["--resolution", "nan"]),
    (["--resolution", "-0.001"], ["--resolution", "-0.001"]),
    (["--speed", "-200"], ["--speed", "-200"]),
    (["--speed", "inf"], ["--speed", "inf"]),
    (["--travel", "-5"], ["--travel", "-5"]),
    (["--travel", "0"], ["--travel", "0"]),
    (["--seed", "-1"], ["--seed", "-1"]),
    (["--seed", str(2**32)], ["--seed", str(2**32)]),
    (["--scale-error", "-1000000"], ["--scale-error", "-1e+06"]),
    (["--periodic-um", "-1"], ["--periodic-um", "-1"]),
    (["--period-mm", "0"], ["--period-mm", "0"]),
    (["--noise-um", "nan"], ["--noise-um", "nan"]),
    # 150 mm of 1e-9 mm microsteps do not fit the device's 32-bit positions
    (["--resolution", "1e-8", "--speed", "1"], ["--travel", "--resolution", "1e-08"]),
    (["--speed", "1e-9"], ["--speed", "1e-09"]),
    (["--tcp", "not-an-address"], ["--tcp", "not-an-address"]),
    (["--tcp", "127.0.0.1:99999"], ["--tcp", "127.0.0.1:99999"]),
    (["--tcp", "127.0.0.1:0", "--link", "/tmp/x"], ["--link", "/tmp/x"]),
    (["--interferometer-tcp", "127.0.0.1:0"], ["--interferometer-tcp", "needs --interferometer"]),
    (["--interferometer", "--interferometer-tcp", "127.0.0.1:0"], ["--interferometer-tcp", "needs --tcp"]),
    (["--link", "/nonexistent-folder/stage"], ["--link", "/nonexistent-folder"]),
    (["--axes", "abc"], ["--axes", "abc"]),
]


@pytest.mark.parametrize("argv,words", BAD, ids=[" ".join(a) for a, _ in BAD])
def test_parse_refuses_with_the_option_and_value(argv, words):
    with pytest.raises(ConfigError) as err:
        parse(argv)
    line = str(err.value)
    assert "\n" not in line and all(w in line for w in words), line


def test_defaults_and_real_configurations_pass():
    parse([])
    parse(["--rotary", "--resolution", "0.000234375", "--speed", "720", "--travel", "1e9"])  # no travel when rotary
    parse(["--tcp", ":0", "--interferometer", "--interferometer-tcp", "127.0.0.1:0", "--seed", str(2**32 - 1)])


def test_cli_refuses_in_one_line(capsys):
    assert main(["devices", "simulate-stage", "--speed", "-200"]) == 2
    out, err = capsys.readouterr()
    assert out == "" and len(err.strip().splitlines()) == 1 and "--speed -200" in err


def test_link_never_replaces_a_file(tmp_path):
    f = tmp_path / "notes.txt"
    f.write_text("keep me")
    with pytest.raises(ConfigError, match="exists and is not a link"):
        parse(["--link", str(f)])
    assert f.read_text() == "keep me"


def test_process_refused_before_a_child_starts(tmp_path):
    with pytest.raises(ConfigError, match="--address 0"):
        SimulatorProcess("--address", "0", folder=tmp_path)


def test_process_reports_a_port_in_use_in_one_line(tmp_path):
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen(1)
        port = taken.getsockname()[1]
        with pytest.raises(ConfigError) as err:
            SimulatorProcess("--tcp", f"127.0.0.1:{port}", pty=False, folder=tmp_path)
    assert "--tcp" in str(err.value) and str(port) in str(err.value) and "\n" not in str(err.value)


def test_bad_fault_and_data_values_are_refused_not_fatal():
    linear, rotary = ZaberSim(), ZaberSim(limit_max=None)
    for sim in (linear, rotary):
        for line in (
            "/1 0 sim mute abc",
            "/1 0 sim delay nan",
            "/1 0 sim delay -1",
            "/1 0 sim delay 1e9",
            "/1 0 sim exit -3",
            "/1 0 sim garble 99999999999999",
            "/1 1 move abs " + "9" * 400,
            "/1 1 move abs 2147483648",
            "/1 1 move rel -2147483648",
            "/1 1 set maxspeed " + "9" * 30,
            "/1 1 set maxspeed 0",
        ):
            (reply,) = sim.handle(line)
            assert " RJ " in reply and reply.endswith("BADDATA"), (line, reply)
        assert sim.handle("/1 0 sim explode")[0].endswith("RJ IDLE WR BADCOMMAND")
        assert sim.delay == 0.0 and sim.mute == 0 and sim.garble == 0
        assert sim.handle("/1 1 get pos") == ["@01 1 OK IDLE WR 0"]  # still serving, nothing moved


def test_junk_on_the_ports_does_not_end_the_simulator(tmp_path):
    with SimulatorProcess(pty=False, interferometer=True, folder=tmp_path) as sim:
        for port, query, answer in (
            (sim.stage_port, b"/1 1 get pos\n", b"@01 1 OK"),
            (sim.interferometer_port, b"POS?\n", b"POS "),
        ):
            host, _, p = port[len("socket://") :].rpartition(":")
            with socket.create_connection((host, int(p)), timeout=5) as c:
                # non-ASCII bytes echoed in an error reply, then 200 kB without a line end
                c.sendall(b"\xff\xfe junk\n" + b"x" * 200_000 + b"\n" + query)
                got = b""
                while answer not in got:
                    chunk = c.recv(4096)
                    assert chunk, got[-200:]
                    got += chunk
        assert sim.proc.poll() is None
