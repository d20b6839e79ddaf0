"""The HTTP face: the FastAPI app, its routes and schemas, the browser UI."""
