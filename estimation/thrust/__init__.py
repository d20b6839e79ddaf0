"""Thrust: calibration curves and the thrust law."""

#: The thrust curve is fitted per side (forward, reverse): each needs at least this many
#: static points (``curve.fit_thrust_curve``); a sweep with fewer is refused before it runs.
MIN_POINTS_PER_SIDE = 4
