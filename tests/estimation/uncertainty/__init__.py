"""The GUM budget (estimation/uncertainty)."""
