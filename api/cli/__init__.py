"""The ``rig`` command line face: one module per command group.

Every process the ``rig`` program starts loads OpenBLAS with one thread unless
``OPENBLAS_NUM_THREADS`` says otherwise: a command, ``rig serve``, and what they start (the
analysis workers, the warm-up, the simulators), which inherit the environment. NumPy and SciPy
each load their own OpenBLAS, and each starts a worker thread per core that spins while it
waits for work; the rig's matrices are small (a fit gains nothing from more threads,
``estimation.blas_threads``), so on a 2-core rig PC the spin was CPU taken from the
acquisition clock: 0.2–0.3 s of CPU per ``rig estimate`` of a recorded tow, a decay or the
ship2d record, 4–12 % (interleaved runs; same wall time). Set here, in the package's first
lines, so that it precedes every import of NumPy by the command's modules.
"""

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
