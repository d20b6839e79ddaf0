"""The 6-DOF vehicle and its sensitivity (estimation/vehicle)."""
