"""The single-DOF equation (estimation/motion): free decays, their windows and warnings."""
