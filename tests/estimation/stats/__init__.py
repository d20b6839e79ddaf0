"""The statistics layer (estimation/stats): rules, σ, whiteness, misfit."""
