"""Published records nobody here wrote (../shared/data/real)."""
