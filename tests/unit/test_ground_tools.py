"""`vtol fly`: both processes in lockstep, a profile flown end to end, log and figures written."""

from __future__ import annotations

import sys


# ---- the processes' command lines and the flight-log schema, without processes -----------------------------------
def test_a_command_description_left_alone_adds_nothing_and_each_field_its_option(tmp_path):
    from tiltrotor_sitl._commands import AutopilotCommand, LinkPorts, SimCommand, Zenoh

    assert SimCommand().argv() == [sys.executable, "-m", "sim_bridge"]
    assert AutopilotCommand().argv() == [sys.executable, "-m", "autopilot"]
    plant = SimCommand(
        port=4600,
        spawn_alt=100.0,
        realtime_speed=2.0,
        duration_s=3.5,
        lockstep_timeout_s=9.0,
        summary=True,
        zenoh=Zenoh.listening("tcp/127.0.0.1:7000"),
        extra=("--sysid", "2"),
    )
    assert plant.argv()[3:] == ["--port", "4600", "--spawn-alt", "100.0", "--realtime", "--speed", "2.0",
                                "--duration", "3.5", "--lockstep-timeout", "9.0", "--summary",
                                "--zenoh-listen", "tcp/127.0.0.1:7000", "--sysid", "2"]  # fmt: skip
    autopilot = AutopilotCommand(instance=3, links=LinkPorts(1, 2, 3, 4), controller="mpc", offboard_lockstep=True,
                                 log=tmp_path / "log.csv", quiet=True, zenoh=Zenoh.off())  # fmt: skip
    assert autopilot.argv()[3:] == ["--instance", "3", "--gcs-port", "1", "--gcs-remote-port", "2", "--api-port", "3",
                                    "--api-remote-port", "4", "--controller", "mpc", "--offboard-lockstep",
                                    "--log", str(tmp_path / "log.csv"), "--quiet", "--no-zenoh"]  # fmt: skip


def test_the_flight_log_reads_back_what_it_writes_and_refuses_other_files(tmp_path):
    import pytest

    from transport.flight_log import COLUMNS, MODE, NUMERIC_COLUMNS, FlightLogWriter, T, read_flight_log

    assert COLUMNS[-1] == MODE and len(COLUMNS) == len(set(COLUMNS)) == len(NUMERIC_COLUMNS) + 1
    path = tmp_path / "log.csv"
    with open(path, "w", newline="") as handle:
        writer = FlightLogWriter(handle)
        for k in range(3):
            writer.write([k / 100 + 0.99] + [1.234567] * (len(NUMERIC_COLUMNS) - 1), "MC" if k < 2 else "FW")
    log = read_flight_log(path)
    assert log.modes == ["MC", "MC", "FW"] and list(log) == list(NUMERIC_COLUMNS)
    assert log[T].tolist() == [0.99, 1.0, 1.01] and log[NUMERIC_COLUMNS[1]].tolist() == [1.2346] * 3
    assert log.since(1.0)[T].tolist() == pytest.approx([0.0, 0.01]) and log.since(1.0).modes == ["MC", "FW"]
    path.write_text("t,north\n0,1\n")
    with pytest.raises(ValueError, match="not a flight log"):
        read_flight_log(path)
