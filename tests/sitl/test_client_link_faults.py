"""A ground station behind a lossy link (docs/faults.md): through the seeded fault proxy, with loss, duplication,
reordering and jitter both ways, commands are acknowledged with retries, Offboard flies on a lossy set-point
stream, and a link that drops everything triggers the Offboard-loss failsafe."""

from __future__ import annotations

from tests.sitl.ground_station import HOLD, OFFBOARD, GroundStation
from tiltrotor_sitl import Vehicle
from tiltrotor_sitl._free_ports import free_udp_port
from tiltrotor_sitl.fault_proxy import FaultProxy, Faults
from transport.mavlink import mavlink as M

LOSSY = Faults(loss=0.3, duplicate=0.1, reorder=0.1, jitter_s=0.01)


def test_commands_and_offboard_through_a_lossy_link_then_the_link_lost(tmp_path):
    nobody = free_udp_port()  # the vehicle's GCS link sends here until our HEARTBEAT reaches it through the proxy
    # COM_OF_LOSS_T 5 s and real time: a test process starved of the CPU for seconds on a busy machine (CI runs two
    # tests at once) is not a lost link; what this test is about is the proxy's faults, and 30 % loss at 50 Hz never
    # leaves a 5 s gap
    with (
        Vehicle(
            spawn_alt=30.0, speed=1.0, truth=False, gcs_port=nobody, folder=tmp_path, params={"COM_OF_LOSS_T": 5.0}
        ) as vehicle,
        FaultProxy(vehicle.ports.links.gcs_bind, upstream=LOSSY, downstream=LOSSY, seed=7) as proxy,
    ):
        gs = GroundStation(proxy.port, vehicle.sysid, speaks_first=True)
        try:
            gs.connect()
            for _ in range(10):  # Hold asked 10 times: each acknowledged, with retries where the command or
                # its ACK was lost (with 30 % loss each way, 10 round trips without a loss: 1 in 1200)
                ack = gs.command(M.MAV_CMD_DO_SET_MODE, M.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, 4, 3, retry_s=0.3)
                assert ack.result == M.MAV_RESULT_ACCEPTED
            assert gs.retries > 0
            # A duplicated or retried Hold still in flight would be obeyed after the Offboard below (PX4 would
            # obey it too), and its late ACK would answer the Offboard's wait: let them all arrive first.
            gs.pump(0.5)
            stream = lambda: gs.velocity_setpoint(2.0, 0.0, 0.0)  # noqa: E731 (20 Hz or so, with the pump)
            gs.wait_sim(0.5, every=stream)
            offboard = gs.command(M.MAV_CMD_DO_SET_MODE, M.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, 6, 0, retry_s=0.3)
            assert offboard.result == M.MAV_RESULT_ACCEPTED
            gs.wait(lambda: gs.velocity[0] > 1.5, "2 m/s north", 60.0, every=stream)
            # the vehicle says its mode in a HEARTBEAT each simulated second (and at each change), 30 % of them
            # lost: the last one heard may still be from before the Offboard
            gs.wait(lambda: gs.mode == OFFBOARD, "a HEARTBEAT in Offboard", 60.0, every=stream)
            heard = len(gs.heartbeats)
            gs.wait_sim(3.0, every=stream)
            modes = {heartbeat.custom_mode for _, heartbeat in gs.heartbeats[heard:]}
            assert modes <= {OFFBOARD}, gs.statustexts  # 30 % loss is no loss of the stream
            counters = proxy.summary()
            assert counters["upstream"]["lost"] > 10 and counters["upstream"]["duplicated"] > 5
            assert counters["downstream"]["lost"] > 10 and counters["downstream"]["reordered"] > 5

            # the ground station's datagrams no longer arrive; the vehicle's all do, so the HEARTBEAT that says
            # the failsafe's mode is not lost
            proxy.set_faults(Faults(loss=1.0), Faults())
            lost_at = gs.sim_time
            gs.wait(lambda: gs.mode != OFFBOARD, "the Offboard-loss failsafe", 60.0, every=stream)
            assert gs.mode == HOLD and gs.armed
            assert 4.8 < gs.sim_time - lost_at < 6.5
            print(f"retries {gs.retries}, proxy {proxy.summary()}")
        finally:
            gs.close()
