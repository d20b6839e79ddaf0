"""The term library across record kinds and scales: recovery, false claims, coverage."""
