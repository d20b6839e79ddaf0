"""Thruster serial protocol, driver, simulated controller and thrust calibration."""
