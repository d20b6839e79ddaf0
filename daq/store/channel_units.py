"""What each exported column means: unit, long name and resolution, from the rig file
stored with the run (``[[channels]] unit``, ``type``, ``scale``, ``offset``).

The resolution lets text exports write ``0.285`` where the stored double is
``0.28500000000000003``: a value of a channel read as an integer count is
``raw × scale + offset``, exact at as many decimals as ``scale`` and ``offset`` have, so
rounding to those decimals loses nothing the rig measured. ``float32`` channels keep
the shortest text that round-trips as a float32; channels of unknown origin (imported
without a rig file) keep Python's shortest round-trip ``repr``.
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from daq.store.run_records import RunInfo, SampleTable
from daq.vocabulary import AXES, DRIVE_FIELD, LOGGED_DRIVE_CHANNEL, thruster_telemetry_unit

#: Decimals of the time columns (1 µs; the store keeps start times to the µs as well).
TIME_DECIMALS = 6
#: Most decimals a scaled channel is written with (its scale is finer than this: repr).
MAX_DECIMALS = 12
#: Unit of the position (and logged drive) channel an imported run of each kind has by
#: contract (UDUNITS text: "N m", not "N·m").
POSITION_UNITS = {terms.position_channel: terms.unit for terms in AXES.values()} | {
    channel: DRIVE_FIELD[kind][1].replace("·", " ")
    for kind, channel in LOGGED_DRIVE_CHANNEL.items()
}


@dataclass(frozen=True)
class ColumnInfo:
    """One column of an export: ``units`` (UDUNITS/CF text, ``"1"`` dimensionless, ``""``
    unknown), ``long_name``, and ``decimals`` (resolution; None: unknown) or
    ``single`` (a float32 reading)."""

    name: str
    units: str
    long_name: str
    decimals: int | None = None
    single: bool = False

    def attrs(self) -> dict[str, str]:
        """CF variable attributes."""
        return {"units": self.units, "long_name": self.long_name}


#: The bookkeeping columns every export has before the channels.
SAMPLE_COLUMNS: dict[str, ColumnInfo] = {
    "t": ColumnInfo("t", "s", "time since the run's first sample", TIME_DECIMALS),
    "seq": ColumnInfo("seq", "1", "clock slot number (gaps = skipped slots)", 0),
    "t_mono": ColumnInfo("t_mono", "s", "host monotonic clock at the read", TIME_DECIMALS),
    "t_wall": ColumnInfo(
        "t_wall", "s since 1970-01-01 00:00:00 UTC", "host wall clock at the read", TIME_DECIMALS
    ),
    "quality": ColumnInfo("quality", "1", "quality flags: 1 stale, 2 read error, 4 overrun", 0),
}


def _decimals(*numbers: float) -> int | None:
    """Fewest decimals (≤ MAX_DECIMALS) that write every number exactly, else None."""
    for d in range(MAX_DECIMALS + 1):
        if all(math.isclose(n * 10**d, round(n * 10**d), abs_tol=1e-9) for n in numbers):
            return d
    return None


def _rig_channels(run: RunInfo) -> dict[str, dict[str, Any]]:
    """The ``[[channels]]`` tables of the run's stored rig file ({} when it has none or
    it cannot be read: an export never fails on an old or odd rig file)."""
    try:
        data = tomllib.loads(run.rig_toml or "")
    except tomllib.TOMLDecodeError:
        return {}
    channels = data.get("channels")
    if not isinstance(channels, list):
        return {}
    named = (c for c in channels if isinstance(c, dict) and isinstance(c.get("name"), str))
    return {c["name"]: c for c in named}


def _channel_info(name: str, spec: dict[str, Any] | None) -> ColumnInfo:
    label = name.replace("_", " ")
    if spec is None:
        units = POSITION_UNITS.get(name) or thruster_telemetry_unit(name) or ""
        note = "" if units else " (unit unknown: imported without a rig file)"
        return ColumnInfo(name, units, label + note)
    if spec.get("type") == "bool":
        return ColumnInfo(name, "1", f"{label} (0/1)", 0)
    units = str(spec.get("unit") or "1")
    if spec.get("type") == "float32":
        return ColumnInfo(name, units, label, single=True)
    scale, offset = spec.get("scale", 1.0), spec.get("offset", 0.0)
    numbers = isinstance(scale, int | float) and isinstance(offset, int | float)
    return ColumnInfo(name, units, label, _decimals(scale, offset) if numbers else None)


def column_infos(run: RunInfo) -> dict[str, ColumnInfo]:
    """Every column of the run's export, in order: the sample columns, then its channels."""
    specs = _rig_channels(run)
    channels = {name: _channel_info(name, specs.get(name)) for name in run.channel_names}
    return SAMPLE_COLUMNS | channels


def _shortest_single(values: np.ndarray) -> np.ndarray:
    """Each value as the double nearest the shortest text of its float32."""
    return np.array([float(repr(v)) for v in values.astype(np.float32).tolist()], dtype=float)


def at_resolution(values: np.ndarray, info: ColumnInfo) -> np.ndarray:
    """``values`` rounded to the column's resolution (NaN stays NaN), so that ``repr`` of
    each is its shortest exact text."""
    values = np.asarray(values, dtype=float)
    if info.single:
        out = values.copy()
        finite = np.isfinite(values)
        out[finite] = _shortest_single(values[finite])
        return out
    if info.decimals is None:
        return values
    return np.round(values, info.decimals)


def table_at_resolution(table: SampleTable, infos: dict[str, ColumnInfo]) -> SampleTable:
    """The table with times and channels at their resolution (for text exports)."""
    return replace(
        table,
        t_mono=at_resolution(table.t_mono, infos["t_mono"]),
        t_wall=at_resolution(table.t_wall, infos["t_wall"]),
        channels={
            name: at_resolution(values, infos[name]) if name in infos else values
            for name, values in table.channels.items()
        },
    )


def units_line(infos: dict[str, ColumnInfo]) -> str:
    """``t=s, seq=1, …, tow_position=m`` (``?`` for an unknown unit)."""
    return ", ".join(f"{name}={info.units or '?'}" for name, info in infos.items())
