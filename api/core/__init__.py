"""The application core: the rig service, the job runner, the live stream."""
