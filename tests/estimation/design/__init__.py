"""The campaign planner (estimation/design)."""
