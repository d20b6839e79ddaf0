"""The 6-DOF vehicle: description, dynamics, responses, sensitivity."""
