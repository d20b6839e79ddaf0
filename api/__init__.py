"""The faces: FastAPI app, job runner, live stream, browser UI and the rig CLI."""
