"""The application core (``api.core``) and its two faces: HTTP with the browser UI
(``api.http``) and the ``rig`` command line (``api.cli.main``)."""
