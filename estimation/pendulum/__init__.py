"""Pendulum free decays: data, simulation, the three methods, fit, report."""

#: The ways a pendulum decay is estimated, the default first (``pendulum_estimate``); here,
#: so a face lists them without importing the estimation (``rig estimate --method``).
PENDULUM_METHODS: tuple[str, ...] = (
    "output-error",
    "damped-fit",
    "log-decrement",
    "equation-error",
)
