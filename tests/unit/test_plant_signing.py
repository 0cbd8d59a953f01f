"""The plant link signed with a shared key (docs/plant-link.md#signing): the keyed pair flies; an unkeyed or
wrongly keyed sender never gets the plant, even before its autopilot arrives; a bad key file is refused."""

from __future__ import annotations

import pytest

from transport.link_signing import KeyFileRefused, parse_key


@pytest.mark.parametrize("text, reason", [
    ("abc", "3 characters, 64 hexadecimal digits expected"),
    ("zz" * 32, "not hexadecimal"),
    ("00" * 32, "an all-zero key"),
])  # fmt: skip
def test_a_key_must_be_64_hex_digits_and_not_zero(text, reason):
    with pytest.raises(KeyFileRefused, match=reason):
        parse_key(text)
    assert parse_key(" " + "ab" * 32 + "\n") == bytes([0xAB] * 32)
