"""Instance ports (transport/ports.py): every instance 0 .. 999 has ports of its own, and a campaign's port block
is claimed by binding it."""

from __future__ import annotations

import re

from transport.ports import MAX_INSTANCE, Ports


def _ports(instance: int) -> list[int]:
    ports = Ports(instance)
    zenoh = [int(re.search(r":(\d+)$", endpoint).group(1)) for endpoint in (ports.zenoh_plant, ports.zenoh_autopilot)]
    return [ports.plant, ports.gcs_bind, ports.api_bind, ports.api_remote, *zenoh]


def test_no_port_of_an_instance_is_a_port_of_another() -> None:
    owner: dict[int, int] = {}
    for instance in range(MAX_INSTANCE + 1):
        for port in _ports(instance):
            assert owner.setdefault(port, instance) == instance, f"port {port}: instances {owner[port]} and {instance}"
            assert port != Ports(instance).gcs_remote and 1024 < port < 65536
    assert (Ports(9).api_remote, Ports(10).api_remote, Ports(99).zenoh_plant, Ports(100).zenoh_plant) == \
        (14549, 15580, "tcp/127.0.0.1:7546", "tcp/127.0.0.1:7647")  # fmt: skip
