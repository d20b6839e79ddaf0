"""What the store hands out: frozen records of runs, events and results, and sample
tables as numpy arrays."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from datetime import UTC, datetime
from typing import TYPE_CHECKING, Any, overload

from daq.parameter_labels import labelled
from daq.sample import Quality, Sample

if TYPE_CHECKING:  # annotations only: listing runs starts without numpy
    import numpy as np


class RunNotFound(KeyError):
    """No run has this id (or id prefix)."""

    def __str__(self) -> str:  # KeyError would repr() the message
        return str(self.args[0]) if self.args else "run not found"


class ResultNotFound(KeyError):
    """No result has this id."""

    def __str__(self) -> str:
        return str(self.args[0]) if self.args else "result not found"


class AmbiguousRunId(ValueError):
    """A run id prefix matches more than one run."""


class DuplicateSample(ValueError):
    """A sample with the same (run, seq) is already stored."""


@overload
def to_datetime(unix_s: float) -> datetime: ...
@overload
def to_datetime(unix_s: None) -> None: ...
def to_datetime(unix_s: float | None) -> datetime | None:
    """Aware UTC datetime of a Unix time (None stays None)."""
    return None if unix_s is None else datetime.fromtimestamp(unix_s, tz=UTC)


def _iso(value: datetime | None) -> str | None:
    return None if value is None else value.isoformat()


@dataclass(frozen=True)
class RunInfo:
    """One run's metadata; times are aware UTC datetimes."""

    id: str
    kind: str
    status: str
    reason: str | None
    parameters: dict[str, Any]
    started_at: datetime
    stopped_at: datetime | None
    sample_count: int
    rig_name: str
    vehicle: str
    channel_names: tuple[str, ...]
    software_version: str
    rig_toml: str
    scenario_toml: str | None
    #: weight | thrusters, None when nothing drove the vehicle (a pendulum).
    drive: str | None = None
    #: recorded | imported; an import keeps the original start as ``started_at``.
    source: str = "recorded"
    source_file: str | None = None
    imported_at: datetime | None = None
    #: Operator, water temperature, notes, tags, free keys (daq.store.run_metadata).
    metadata: dict[str, Any] = field(default_factory=dict)
    #: What the run lost ("7 samples lost in 0.9 s at 12.3 s", from its ``samples_lost``
    #: events; ``daq.sample_losses``), None: nothing, or not ``losses_read``.
    samples_lost: str | None = None
    #: The events were read for ``samples_lost`` (``Store.get_run``; run lists do not).
    losses_read: bool = False

    @property
    def summary(self) -> str:
        """How the run ended and what it lost: "completed, 7 samples lost in 0.9 s at 12.3 s"."""
        ending = self.status + (f" ({self.reason})" if self.reason else "")
        return ending + (f", {self.samples_lost}" if self.samples_lost else "")

    @property
    def duration_s(self) -> float | None:
        """Seconds from start to stop (None while running)."""
        if self.stopped_at is None:
            return None
        return (self.stopped_at - self.started_at).total_seconds()

    def to_json(self, *, include_toml: bool = True) -> dict[str, Any]:
        """A JSON-ready dict (ISO-8601 times)."""
        out: dict[str, Any] = {
            "id": self.id,
            "kind": self.kind,
            "status": self.status,
            "reason": self.reason,
            "parameters": self.parameters,
            "parameters_labelled": [p.to_json() for p in labelled(self.parameters)],
            "started_at": _iso(self.started_at),
            "stopped_at": _iso(self.stopped_at),
            "duration_s": self.duration_s,
            "sample_count": self.sample_count,
            "rig_name": self.rig_name,
            "vehicle": self.vehicle,
            "channel_names": list(self.channel_names),
            "software_version": self.software_version,
            "drive": self.drive,
            "source": self.source,
            "source_file": self.source_file,
            "imported_at": _iso(self.imported_at),
            "metadata": self.metadata,
        }
        if self.losses_read:  # a list does not read them: its runs say nothing of losses
            out |= {"samples_lost": self.samples_lost, "summary": self.summary}
        if include_toml:
            out["rig_toml"] = self.rig_toml
            out["scenario_toml"] = self.scenario_toml
        return out


@dataclass(frozen=True)
class EventInfo:
    """An operator action, fault, limit trip or note, optionally tied to a run."""

    id: int
    run_id: str | None
    time: datetime
    kind: str
    message: str
    data: dict[str, Any] | None

    def to_json(self) -> dict[str, Any]:
        """A JSON-ready dict (ISO-8601 time)."""
        return {
            "id": self.id,
            "run_id": self.run_id,
            "time": _iso(self.time),
            "kind": self.kind,
            "message": self.message,
            "data": self.data,
        }


@dataclass(frozen=True)
class ResultInfo:
    """An estimation or calibration result linked to the runs it came from."""

    id: int
    kind: str
    created_at: datetime
    run_ids: tuple[str, ...]
    software_version: str
    data: dict[str, Any]

    def to_json(self) -> dict[str, Any]:
        """A JSON-ready dict (ISO-8601 time)."""
        return {
            "id": self.id,
            "kind": self.kind,
            "created_at": _iso(self.created_at),
            "run_ids": list(self.run_ids),
            "software_version": self.software_version,
            "data": self.data,
        }


@dataclass(frozen=True)
class SampleTable:
    """A run's samples as columns: ``seq`` (int64), ``t_mono``/``t_wall`` (s, float64),
    ``quality`` (int64 flags), ``channels`` name → float64 array (SI, NaN when unread),
    ``stale`` the stale channel names of each sample."""

    seq: np.ndarray
    t_mono: np.ndarray
    t_wall: np.ndarray
    quality: np.ndarray
    channels: dict[str, np.ndarray]
    stale: tuple[tuple[str, ...], ...] = field(default=())

    def __len__(self) -> int:
        return int(self.seq.shape[0])

    @property
    def t(self) -> np.ndarray:
        """Seconds since the first sample (monotonic clock)."""
        return self.t_mono - self.t_mono[0] if len(self) else self.t_mono.copy()

    def sample(self, index: int) -> Sample:
        """Row ``index`` as a :class:`daq.sample.Sample`."""
        return Sample(
            seq=int(self.seq[index]),
            t_mono=float(self.t_mono[index]),
            t_wall=float(self.t_wall[index]),
            channels={name: float(values[index]) for name, values in self.channels.items()},
            quality=Quality(int(self.quality[index])),
            stale=self.stale[index] if self.stale else (),
        )

    def to_json(self) -> dict[str, Any]:
        """Columns as lists (NaN becomes null)."""

        def clean(values: np.ndarray) -> list[float | None]:
            return [None if math.isnan(v) else v for v in values.tolist()]

        return {
            "seq": self.seq.tolist(),
            "t_mono": self.t_mono.tolist(),
            "t_wall": self.t_wall.tolist(),
            "quality": self.quality.tolist(),
            "channels": {name: clean(values) for name, values in self.channels.items()},
        }
