"""Recordings as the estimators see them: arrays, windows, CSV files."""
