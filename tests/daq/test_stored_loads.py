"""A load derived from a hung weight is stored as people write it: 83.3 N, not
83.30000000000001 N (weight × g carries binary float noise); the value is unchanged to
12 significant digits, far finer than the gram a weight is hung to."""

from __future__ import annotations

import numpy as np
import pytest

from daq.config import load_rig
from daq.procedures.requests import spin_parameters, tow_parameters


@pytest.fixture(scope="module")
def rig():
    return load_rig()


def _written(value: float) -> bool:
    """No float noise: the shortest repr has at most 12 significant digits."""
    digits = repr(abs(value)).replace(".", "").lstrip("0").split("e")[0]
    return len(digits) <= 12


def test_tow_forces_and_spin_torques_are_stored_without_float_noise(rig):
    noisy_before = 0
    for force in np.round(np.arange(0.5, 99.0, 0.7), 1):
        params = tow_parameters({"force_n": float(force)}, rig)
        exact = params.hung_mass_kg * rig.rig.g
        noisy_before += not _written(exact)
        assert _written(params.force_n), params.force_n
        assert params.force_n == pytest.approx(exact, rel=1e-12)
    assert noisy_before > 0  # weight × g alone would have stored noise
    for grams in range(50, 2000, 37):
        params = spin_parameters({"weight_kg": grams / 1000}, rig)
        assert _written(params.torque_nm), params.torque_nm
        r = rig.geometry.spin_drum_radius_m
        assert params.torque_nm == pytest.approx(grams / 1000 * rig.rig.g * r, rel=1e-12)
