"""The pendulum route (estimation/pendulum)."""
