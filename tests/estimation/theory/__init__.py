"""Water properties and added-mass theory (estimation/water.py, estimation/theory)."""
