"""Statistics every fit shares: BIC, RMSE, residual diagnostics."""
