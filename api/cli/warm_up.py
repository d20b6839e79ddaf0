"""``rig warm-up``: the estimator's compiled kernels made ready before the first estimate
(``estimation.motion.compiled_warm_up``); and the same in a background process for ``rig serve``."""

from __future__ import annotations

import subprocess
import sys

import click


@click.command("warm-up")
def warm_up() -> None:
    """Compile the estimator's kernels now (5-9 s of CPU once per install), so the first
    estimate does not wait for them."""
    from estimation.motion.compiled_warm_up import warm_up as compile_kernels

    seconds = compile_kernels()
    click.echo(f"estimator kernels ready ({seconds:.1f} s of CPU)")


def warm_up_in_background() -> subprocess.Popen:
    """``python -m estimation.motion.compiled_warm_up`` as a detached process at nice 19: it
    compiles the kernels when numba's cache is cold, else loads them in ~0.5 s of CPU."""
    return subprocess.Popen(
        [sys.executable, "-m", "estimation.motion.compiled_warm_up"],
        stdin=subprocess.DEVNULL,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        start_new_session=True,  # Ctrl-C of the service is not its
    )
