"""Laser interferometer: CSV import (delimiters, decimal comma, units, report lines),
the serial line protocol against the simulator and in stream mode, the simulated one."""

from __future__ import annotations

import os
import threading
import time
import tty

import numpy as np
import pytest

from camcmm.api import DeviceError, DeviceTimeout, InputError
from camcmm_plugins.devices.interferometer import (
    CsvInterferometer,
    SerialInterferometer,
    SimulatedInterferometer,
    parse_position,
    read_interferometer_csv,
)
from camcmm_plugins.devices.simulator import SimulatorProcess
from camcmm_plugins.devices.zaber import ZaberLinearStage

TRUE_MM = np.array([0.0, 10.000312, 20.000598, 29.999871, 40.001234])


def test_parse_position_units():
    assert parse_position("POS 12.5 mm") == 12.5
    assert parse_position("12500 um") == pytest.approx(12.5)
    assert parse_position("12500 µm") == pytest.approx(12.5)
    assert parse_position("-0.0125 m") == pytest.approx(-12.5)
    assert parse_position("1 in") == 25.4
    assert parse_position("3.25") == 3.25
    for bad in ("POS", "12.5 furlong", "hello"):
        with pytest.raises(ValueError):
            parse_position(bad)


def test_csv_with_report_lines_and_a_header(tmp_path):
    lines = [
        "Linear measurement report",
        "Operator,A. N. Other",
        "Date,2024-03-01",
        "",
        "Target (mm),Run,Reading (mm),Time",
    ]
    lines += [f"{t:.0f},1,{v:.6f},10:00:{k:02d}" for k, (t, v) in enumerate(zip(np.arange(0, 50, 10), TRUE_MM))]
    p = tmp_path / "run.csv"
    p.write_text("\n".join(lines))
    out = read_interferometer_csv(p)
    assert out["column"] == "Reading (mm)" and out["unit"] == "mm"
    np.testing.assert_array_equal(out["positions"], TRUE_MM)
    np.testing.assert_array_equal(out["targets"], np.arange(0, 50, 10))
    assert out["times"][2] == "10:00:02"


def test_csv_semicolon_decimal_comma_micrometres(tmp_path):
    p = tmp_path / "eu.csv"
    rows = ["Index;Position [um];Temperature"]
    rows += [f"{k};{v * 1000:.3f};20,1".replace(".", ",") for k, v in enumerate(TRUE_MM)]
    p.write_text("\n".join(rows), encoding="utf-8")
    out = read_interferometer_csv(p)
    assert out["unit"] == "um"
    np.testing.assert_allclose(out["positions"], TRUE_MM, atol=1e-9)


def test_csv_without_header_column_by_index_and_unit(tmp_path):
    p = tmp_path / "bare.txt"
    p.write_text("\n".join(f"{k}\t{v * 1e6:.0f}" for k, v in enumerate(TRUE_MM)))
    out = read_interferometer_csv(p, column=1, unit="nm")
    np.testing.assert_allclose(out["positions"], np.round(TRUE_MM * 1e6) / 1e6, atol=1e-12)
    assert out["column"] == "column 1"


def test_csv_errors_name_file_row_and_column(tmp_path):
    p = tmp_path / "bad.csv"
    p.write_text("Target,Reading (mm)\n0,0.0\n10,oops\n20,20.0\n")
    with pytest.raises(InputError, match=r"bad.csv: row 3, column 'Reading \(mm\)': 'oops' is not a number"):
        read_interferometer_csv(p, column="reading")
    with pytest.raises(InputError, match="no column named 'laser'"):
        read_interferometer_csv(p, column="laser")
    with pytest.raises(InputError, match="cannot read"):
        read_interferometer_csv(tmp_path / "missing.csv")
    (tmp_path / "words.csv").write_text("a,b\nc,d\n")
    with pytest.raises(InputError, match="no numeric rows"):
        read_interferometer_csv(tmp_path / "words.csv")


def test_csv_interferometer_hands_out_readings_in_order(tmp_path):
    p = tmp_path / "run.csv"
    p.write_text("Reading (um)\n" + "\n".join(f"{v * 1000:.3f}" for v in TRUE_MM))
    laser = CsvInterferometer(str(p)).connect()
    assert [laser.read() for _ in TRUE_MM] == pytest.approx(list(TRUE_MM), abs=1e-9)
    with pytest.raises(DeviceError, match="all 5 readings of the file are used"):
        laser.read()
    laser.reset()
    assert laser.read() == pytest.approx(0.0)
    with pytest.raises(DeviceError, match="cannot set the datum"):
        laser.zero()


def test_serial_interferometer_against_the_simulator(tmp_path):
    res, ppm, amp = 0.0001, 50.0, 0.4  # periodic lead-screw error of 0.4 um, period 5 mm
    with SimulatorProcess(
        "--resolution",
        str(res),
        "--scale-error",
        str(ppm),
        "--periodic-um",
        str(amp),
        "--period-mm",
        "5",
        interferometer=True,
        folder=tmp_path,
    ) as sim:
        stage = ZaberLinearStage(sim.stage_port, resolution=res).connect()
        laser = SerialInterferometer(sim.interferometer_port, name="xl80").connect()
        stage.home()
        laser.zero()

        def truth(x):  # the simulator's documented model, computed here independently
            return x * (1 + ppm * 1e-6) + amp * 1e-3 * np.sin(2 * np.pi * x / 5.0)

        for target in (7.3, 33.1, 61.25):
            x = stage.move_abs(target)
            assert laser.read() == pytest.approx(truth(x) - truth(0.0), abs=2e-7)
        m = laser.read_mean(4)
        assert m["n"] == 4 and m["std"] == 0.0 and m["unit"] == "mm"
        sim.kill()
        with pytest.raises(DeviceError, match="interferometer 'xl80' on .*port lost"):
            laser.read()


def test_stream_mode_takes_the_newest_line():
    master, slave = os.openpty()
    tty.setraw(slave)
    port = os.ttyname(slave)
    stop = threading.Event()

    def device():
        k = 0
        while not stop.is_set():
            os.write(master, f"{k * 0.001:.6f} mm\r\n".encode())
            k += 1
            time.sleep(0.005)

    t = threading.Thread(target=device, daemon=True)
    t.start()
    try:
        laser = SerialInterferometer(port, mode="stream", timeout=0.5).connect()
        a = laser.read()
        time.sleep(0.1)
        b = laser.read()
        assert b - a > 0.01  # not a stale line queued 0.1 s ago
    finally:
        stop.set()
        t.join()
    laser2 = SerialInterferometer(port, mode="stream", timeout=0.2).connect()
    with pytest.raises(DeviceTimeout, match="no reading within 0.2 s"):
        laser2.read()
    os.close(master)
    os.close(slave)


def test_simulated_interferometer_follows_a_stage():
    from camcmm_plugins.devices.stage import SimulatedStage

    stage = SimulatedStage("lin", speed=1000.0).connect()
    laser = SimulatedInterferometer(follow=stage, noise=0.001, seed=3).connect()
    stage.home()
    stage.move_abs(42.0)
    m = laser.read_mean(200)
    assert m["mean"] == pytest.approx(42.0, abs=4 * 0.001 / np.sqrt(200))
    assert m["std"] == pytest.approx(0.001, rel=0.2)
