"""Thrust curves and laws (estimation/thrust), from synthetic and published tables."""
