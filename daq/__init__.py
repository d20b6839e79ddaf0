"""Rig configuration, Modbus PLC/encoder client, acquisition clock, run storage,
test procedures and the simulated rig."""
