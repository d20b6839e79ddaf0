"""Per-axis model, fits, effect library and search, results and reports."""

#: The methods a tow or spin can be estimated with (``estimate(method=...)``): the
#: output-error fit and the three least-squares seeds. Here, not beside ``estimate``, so
#: the faces list them without importing the fits.
METHODS: tuple[str, ...] = ("output-error", "ls-raw", "ls-curvefit", "ls-steady")
