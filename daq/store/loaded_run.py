"""One stored run in memory for notebooks and file exports: ``to_pandas()``,
``to_xarray()``, ``to_netcdf(path)``, ``to_parquet(path)``.

pandas, xarray, pyarrow and h5netcdf are imported inside the methods that use them, so
``import daq.store`` (and ``rig --help``) stays light. Values are the stored doubles,
bit for bit (text exports round them to the channel's resolution, binary ones need not).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from daq.store.channel_units import ColumnInfo, column_infos
from daq.store.run_attributes import Attribute, release_time, run_attributes
from daq.store.run_records import EventInfo, ResultInfo, RunInfo, SampleTable

if TYPE_CHECKING:
    import pandas as pd
    import xarray as xr

#: Name and description of the time-from-release coordinate (present when the release
#: is known: a recorded release event, or ``release_time_s`` given at import).
FROM_RELEASE = ColumnInfo(
    "t_from_release", "s", "time since the brake release (host clock; < 0 before it)"
)
#: Long name of the ``time`` coordinate (CF: datetimes are UTC).
WALL_CLOCK = "host wall clock at the read, UTC"
#: Compression of every NetCDF variable (zlib level 4: most of the gain, little time).
NETCDF_COMPRESSION = {"zlib": True, "complevel": 4}


@dataclass(frozen=True)
class LoadedRun:
    """A run's record, all its samples, events and results (see :meth:`Store.load`)."""

    info: RunInfo
    samples: SampleTable
    events: tuple[EventInfo, ...]
    results: tuple[ResultInfo, ...]

    @property
    def id(self) -> str:
        return self.info.id

    @property
    def columns(self) -> dict[str, ColumnInfo]:
        """Unit, long name and resolution of each column (``channel_units``)."""
        return column_infos(self.info)

    @property
    def release_t(self) -> float | None:
        """The brake release, s since the first sample (None: not known)."""
        first = float(self.samples.t_mono[0]) if len(self.samples) else 0.0
        return release_time(self.info, self.events, first)

    def attributes(self) -> dict[str, Attribute]:
        """The run's description as flat attributes (``run_attributes``)."""
        return run_attributes(self.info, self.events, release_t=self.release_t)

    def _from_release(self) -> np.ndarray | None:
        release = self.release_t
        return None if release is None else self.samples.t - release

    def to_pandas(self) -> pd.DataFrame:
        """A DataFrame indexed by ``t`` (s since the first sample) with the columns of a
        CSV export (``seq``, ``t_mono``, ``t_wall`` in Unix s, ``quality``, each channel in
        SI; NaN = not read) plus ``t_from_release`` when the release is known.
        ``df.attrs`` holds the run's attributes, ``units`` and ``long_names`` (column →
        text); ``df.to_parquet`` keeps them."""
        import pandas as pd

        table, infos = self.samples, self.columns
        data: dict[str, np.ndarray] = {
            "seq": table.seq,
            "t_mono": table.t_mono,
            "t_wall": table.t_wall,
            "quality": table.quality,
        }
        from_release = self._from_release()
        if from_release is not None:
            data[FROM_RELEASE.name] = from_release
            infos = infos | {FROM_RELEASE.name: FROM_RELEASE}
        data.update((name, table.channels[name]) for name in self.info.channel_names)
        frame = pd.DataFrame(data, index=pd.Index(table.t, name="t"))
        frame.attrs = {
            **self.attributes(),
            "units": {name: info.units for name, info in infos.items()},
            "long_names": {name: info.long_name for name, info in infos.items()},
        }
        return frame

    def to_xarray(self) -> xr.Dataset:
        """A Dataset along ``t`` (s since the first sample) with coordinates
        ``t_from_release`` (s, when the release is known) and ``time`` (UTC wall clock,
        datetime64), data variables ``seq``, ``t_mono``, ``quality`` and every channel,
        each with CF ``units`` and ``long_name``; the run's attributes as global ones."""
        import xarray as xr

        table, infos = self.samples, self.columns
        coords: dict[str, Any] = {"t": ("t", table.t, infos["t"].attrs())}
        from_release = self._from_release()
        if from_release is not None:
            coords[FROM_RELEASE.name] = ("t", from_release, FROM_RELEASE.attrs())
        wall = np.round(table.t_wall * 1e6).astype("int64").astype("datetime64[us]")  # µs
        coords["time"] = ("t", wall.astype("datetime64[ns]"), {"long_name": WALL_CLOCK})
        variables = {
            name: ("t", getattr(table, name), infos[name].attrs())
            for name in ("seq", "t_mono", "quality")
        }
        for name in self.info.channel_names:
            variables[name] = ("t", table.channels[name], infos[name].attrs())
        return xr.Dataset(variables, coords=coords, attrs=self.attributes())

    def to_netcdf(self, path: str | Path) -> Path:
        """Write :meth:`to_xarray` as NetCDF-4 (HDF5, via h5netcdf; zlib-compressed);
        ``xarray.open_dataset(path)`` reads it back with units and attributes."""
        dataset = self.to_xarray()
        encoding = {name: dict(NETCDF_COMPRESSION) for name in dataset.data_vars}
        path = Path(path)
        dataset.to_netcdf(path, engine="h5netcdf", encoding=encoding)
        return path

    def to_parquet(self, path: str | Path) -> Path:
        """Write :meth:`to_pandas` as Parquet (pyarrow): each field's ``units`` and
        ``long_name`` in its field metadata, the run's attributes, units and long names
        in ``df.attrs`` (``pandas.read_parquet`` restores them)."""
        import pyarrow as pa

        frame = self.to_pandas()
        schema = pa.Schema.from_pandas(frame)
        units, long_names = frame.attrs["units"], frame.attrs["long_names"]
        for name in units:
            index = schema.get_field_index(name)
            if index >= 0:
                meta = {"units": units[name], "long_name": long_names[name]}
                schema = schema.set(index, schema.field(index).with_metadata(meta))
        path = Path(path)
        frame.to_parquet(path, engine="pyarrow", schema=schema)
        return path
