"""A progress callback that records every report and lets a test wait for one, so tests
synchronise on what a procedure said instead of sleeping for a guessed time."""

from __future__ import annotations

import asyncio
from collections.abc import Callable

from daq.procedures.params import Progress


class ProgressLog:
    """Pass as ``progress=``; ``await log.wait(match, what)`` returns the first report that
    matches (earlier reports count), or fails naming ``what`` after ``timeout_s``."""

    def __init__(self) -> None:
        self.reports: list[Progress] = []
        self._changed = asyncio.Event()

    def __call__(self, report: Progress) -> None:
        self.reports.append(report)
        self._changed.set()

    @property
    def states(self) -> list[str]:
        return [r.state for r in self.reports]

    def count(self, match: Callable[[Progress], bool]) -> int:
        return sum(1 for r in self.reports if match(r))

    async def wait(
        self,
        match: Callable[[Progress], bool],
        what: str,
        *,
        times: int = 1,
        task: asyncio.Task | None = None,
        timeout_s: float = 30.0,
    ) -> Progress:
        """The ``times``-th report that matches; fails at once if ``task`` (the procedure)
        ends first, naming how it ended."""

        async def matched() -> Progress:
            while True:
                hits = [r for r in self.reports if match(r)]
                if len(hits) >= times:
                    return hits[times - 1]
                self._changed.clear()
                await self._changed.wait()

        waiter = asyncio.ensure_future(matched())
        watched: set[asyncio.Future] = {waiter} if task is None else {waiter, task}
        done, _ = await asyncio.wait(
            watched, timeout=timeout_s, return_when=asyncio.FIRST_COMPLETED
        )
        if waiter in done:
            return waiter.result()
        waiter.cancel()
        if task is not None and task in done:
            ended = task.exception() or task.result()
            raise AssertionError(f"{what}: the procedure ended first: {ended!r}")
        last = self.reports[-1].message if self.reports else "nothing"
        raise AssertionError(f"{what}: not reported within {timeout_s} s (last report: {last})")
