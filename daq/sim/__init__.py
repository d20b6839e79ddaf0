"""The simulated rig: plant physics behind a real Modbus server and serial emulator."""
