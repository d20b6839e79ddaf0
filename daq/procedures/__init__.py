"""Test procedures: tow, spin, thrust calibration, sequences."""
