"""The analysis executor of a test's service, watched: which tasks and calls it ran (the
work a route or job must send to the worker process, never do in the rig's)."""

from __future__ import annotations

from api.core.analysis_executor import AnalysisExecutor, AnalysisOutcome, AnalysisTask, TaskStop


class Watching:
    """The runner's executor, recording the outcome of each task it runs."""

    def __init__(self, inner: AnalysisExecutor) -> None:
        self.inner = inner
        self.outcomes: list[AnalysisOutcome] = []

    @property
    def cannot_stop(self) -> str | None:
        return self.inner.cannot_stop

    def run(self, task: AnalysisTask, stop: TaskStop | None = None) -> AnalysisOutcome:
        outcome = self.inner.run(task, stop)
        self.outcomes.append(outcome)
        return outcome

    def close(self) -> None:
        self.inner.close()


class Calls(Watching):
    """The runner's executor, recording the function of each ``call``."""

    def __init__(self, inner: AnalysisExecutor) -> None:
        super().__init__(inner)
        self.called: list[str] = []

    def call(self, store_url, fn, /, *args):
        target = getattr(fn, "func", fn)  # a partial's function
        self.called.append(f"{target.__module__}.{target.__qualname__}")
        return self.inner.call(store_url, fn, *args)
