"""The tow and spin engine (estimation/axis): fits, effects, release, reports."""
