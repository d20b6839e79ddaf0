"""``rig warm-up``: the estimator's compiled kernels made ready before the first estimate
(``estimation.motion.compiled_warm_up``); and the same in a background process for ``rig serve``."""

from __future__ import annotations

import subprocess
import sys

import click

from api.cli.command_table import rig_command


@rig_command()
def warm_up() -> None:
    """Compile the estimator's kernels now (5-17 s of CPU once per install), so the first
    estimate does not wait for them."""
    from estimation.motion.compiled_warm_up import warm_up as compile_kernels

    seconds = compile_kernels()
    click.echo(f"estimator kernels ready ({seconds:.1f} s of CPU)")


def warm_up_in_background() -> subprocess.Popen:
    """``python -m estimation.motion.compiled_warm_up`` as a background process at nice 19: it
    compiles the kernels when numba's cache is cold, else loads them (~1.5 s of CPU).

    It runs in its own process group (the terminal's Ctrl-C, sent to the service's group, is
    not its) but in the service's session: Linux schedules each session as one group
    (autogroup) and shares the CPU fairly between groups, so in a session of its own its
    nice 19 weighed against nothing and it took as much CPU as the service and all its
    threads (a nice-19 loop got 4.0 s of 6 s beside two busy processes, 0.5 s in their
    session), holding off the HTTP thread that shares the clock's interpreter lock."""
    return subprocess.Popen(
        [sys.executable, "-m", "estimation.motion.compiled_warm_up"],
        stdin=subprocess.DEVNULL,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        process_group=0,
    )
