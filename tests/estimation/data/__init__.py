"""Run arrays, windows and imports (estimation/data)."""
