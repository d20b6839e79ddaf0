"""Whether a run of steps goes through a NumPy loop or through a compiled (numba) loop that
gives the same numbers (``estimation.motion.kernel``'s RK4 grid, ``estimation.design.
information``'s run prediction).

Loading numba and a cached loop costs a process ~0.6 s of CPU and ~110 MB, while the NumPy
loops cost 25–120 µs a step, their dispatch: a process that steps little should never load
numba, and one that steps much should load it early. So each loop keeps one
:class:`LoopChoice` per process: NumPy while the compiled loop's module is not loaded
already, the run is short and the process has not spent its NumPy budget.
"""

from __future__ import annotations

import sys
from dataclasses import dataclass


@dataclass
class LoopChoice:
    """The process's choice for one loop: a run steps in NumPy while ``compiled_module`` is
    not in ``sys.modules``, the run has at most ``run_steps`` steps (None: no such limit)
    and the NumPy loop's ``numpy_steps`` in all stay within ``numpy_budget``; else
    compiled. The caller counts what it stepped in NumPy (:meth:`stepped_in_numpy`)."""

    compiled_module: str
    numpy_budget: int
    run_steps: int | None = None
    numpy_steps: int = 0

    def compiled(self, n_steps: int = 0) -> bool:
        """Whether a run of ``n_steps`` steps (0: not known before it ends) runs compiled."""
        if self.compiled_module in sys.modules:
            return True
        if self.run_steps is not None and n_steps > self.run_steps:
            return True
        return self.numpy_steps + n_steps > self.numpy_budget

    def stepped_in_numpy(self, n_steps: int) -> None:
        """Count ``n_steps`` taken in the NumPy loop."""
        self.numpy_steps += n_steps
