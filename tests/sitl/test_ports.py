"""Instance ports (transport/ports.py): every instance 0 .. 999 has ports of its own, and a campaign's port block
is claimed by binding it."""

from __future__ import annotations

import pytest

from tiltrotor_sitl._port_blocks import NoFreeBlock, claim_block


def test_a_claimed_block_is_skipped_by_the_next_claimant() -> None:
    first = claim_block(900, 3)
    try:
        second = claim_block(900, 3)
        try:
            assert {first.instance, second.instance} <= {900, 901, 902} and first.instance != second.instance
            assert second.ports.links.api_remote == second.ground_station.getsockname()[1]
            third = claim_block(900, 3)
            with pytest.raises(NoFreeBlock, match="every instance in 900 .. 902 is in use"):
                claim_block(900, 3)
            third.close()
        finally:
            second.close()
    finally:
        first.close()
    with pytest.raises(ValueError):
        claim_block(998, 5)
