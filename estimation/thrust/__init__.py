"""Thrust: calibration curves and the thrust law."""
