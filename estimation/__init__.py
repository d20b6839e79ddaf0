"""Per-axis models, estimators, effect library, residual diagnostics and reports."""
