"""Storage tests (daq.store)."""
