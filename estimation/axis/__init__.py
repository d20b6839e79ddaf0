"""Per-axis model, fits, effect library and search, results and reports."""
