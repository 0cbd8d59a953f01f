"""The fault campaign through the real processes (issue 12 item 4, docs/faults.md): a faulty plant link, malformed
datagrams at every port while hovering, a faulty client link with the offboard-loss failsafe, SIGKILL and restart."""

from __future__ import annotations

from ground_tools.fault_campaign import fly_plant_link, junk_while_hovering
from tiltrotor_sitl.fault_proxy import DOWNSTREAM, UPSTREAM, Faults

FLIGHT_S = 6.0  # the accel profile's first 6 s: v_sp = 2t up to 12 m/s


def test_the_accel_profile_flies_over_a_plant_link_with_loss_and_jitter(tmp_path):
    clean = fly_plant_link(tmp_path, "clean", None, duration_s=FLIGHT_S)
    faulty = fly_plant_link(tmp_path, "faulty", Faults(loss=0.05, jitter_s=0.005), duration_s=FLIGHT_S, seed=5)
    assert clean.autopilot_rc == faulty.autopilot_rc == 0
    assert faulty.proxy is not None
    up, down = faulty.proxy[UPSTREAM], faulty.proxy[DOWNSTREAM]
    lost = up["lost"] + down["lost"]
    print(f"clean {clean.figures}\nfaulty {faulty.figures}\nproxy {faulty.proxy}\nplant {faulty.plant}")
    assert lost > 0.05 * 2400  # ~5 % each way of ~2 400 steps
    # Each lost state or command is one step that times out and holds the previous command (lockstep); a command
    # that arrives after the step's timeout on a loaded machine (jitter on top of a busy autopilot) counts too.
    assert faulty.plant["steps"] == clean.plant["steps"] == FLIGHT_S * 400
    assert 0.8 * lost <= faulty.plant["missed_commands"] <= 1.15 * lost
    assert faulty.plant["handshakes"] == 1 and faulty.plant["peer_lost"] == 0
    assert clean.plant["missed_commands"] == 0
    # The flight: tracking within 20 % (+ 0.05 m/s) of the clean run, altitude and attitude as clean.
    assert faulty.figures.vx_rmse <= 1.2 * clean.figures.vx_rmse + 0.05
    assert faulty.figures.altitude_deviation <= clean.figures.altitude_deviation + 0.5
    assert abs(faulty.figures.pitch_max_deg - clean.figures.pitch_max_deg) < 3.0
    assert faulty.figures.roll_max_deg < 5.0


def test_malformed_datagrams_at_every_port_while_hovering(tmp_path):
    run = junk_while_hovering(tmp_path, per_port=3000)
    print({name: (i.total, dict(i.sent), i.send_failed) for name, i in run.injected.items()})
    print(run.figures, run.autopilot.get("links"), run.plant.get("foreign"), run.plant.get("dropped"))
    assert run.crashed == [] and run.autopilot_rc == 0 and run.plant_rc == 0
    assert "Traceback" not in run.stderr and "not handled" not in run.stderr
    assert all(injected.total == 3000 for injected in run.injected.values())
    # The flight: still hovering, armed in Hold, within 0.5 m of where it was spawned.
    assert run.autopilot["armed"] and run.autopilot["flight_mode"] == "Hold"
    assert run.figures.altitude_deviation < 0.5 and run.figures.roll_max_deg < 5.0
    # Counted: the plant counts every datagram of a foreign sender; the autopilot counts what the kernel delivered
    # (a loaded machine may drop some from a full socket buffer before anyone can count them).
    assert 0.5 * 3000 <= run.plant["foreign"]["datagrams"] <= 3000
    assert run.plant["failures_applied"] == 0 and run.plant["handshakes"] == 1
    for name in ("gcs", "api"):  # every kind is seen and counted; how many of each the kernel delivered varies
        link = run.autopilot["links"][name]
        dropped = link["dropped"]
        for reason in ("bad_data", "truncated", "bad_crc", "oversized_datagram"):
            assert dropped.get(reason, 0) > 0, (name, reason)
        counted = link["received"] + sum(dropped.values())
        assert 0.1 * run.injected[name].total <= counted <= run.injected[name].total + 1000  # + the GCS's own
    assert run.autopilot["links"]["setpoints_dropped"] > 0
    assert run.files_intact
