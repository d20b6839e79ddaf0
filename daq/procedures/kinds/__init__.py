"""One module per run kind, each holding its ``SPEC`` (``daq.procedures.kind_spec.KindSpec``);
``daq.procedures.run_kinds`` discovers them. A new kind is a new module here."""
