"""`vtol-sim` as a process behind its UDP socket, driven by a small pymavlink peer (issue 2 "Done means")."""

from __future__ import annotations


def test_two_instances_use_shifted_ports():
    from transport.ports import Ports

    assert (Ports(3).plant, Ports(3).gcs_bind, Ports(3).api_bind) == (4563, 18573, 14583)
    assert Ports(3).zenoh_plant == "tcp/127.0.0.1:7450"
