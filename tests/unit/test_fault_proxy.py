"""The seeded UDP fault proxy itself (ground_tools/fault_proxy.py): loss, duplication, reordering, delay, counted."""

from __future__ import annotations

import pytest

from ground_tools.fault_proxy import Faults


def test_bad_faults_are_refused():
    with pytest.raises(ValueError):
        Faults(loss=1.5)
    with pytest.raises(ValueError):
        Faults(jitter_s=-1)
