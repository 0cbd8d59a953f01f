"""The seeded UDP fault proxy itself (tiltrotor_sitl/fault_proxy.py): loss, duplication, reordering, delay, counted."""

from __future__ import annotations

import pytest

from tiltrotor_sitl.fault_proxy import Faults


def test_bad_faults_are_refused():
    with pytest.raises(ValueError):
        Faults(loss=1.5)
    with pytest.raises(ValueError):
        Faults(jitter_s=-1)
