"""Pendulum free decays: data, simulation, the three methods, fit, report."""
