"""Test design: which run to record next, from what the rig can do and what the fit lacks
(planner, criterion and stopping rule: docs/campaigns.md)."""
