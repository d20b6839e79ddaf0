"""The ``rig`` command line face: one module per command group."""
