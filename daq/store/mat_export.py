"""A run as a MATLAB ``.mat`` file (v5, ``scipy.io.savemat``) for ``S = load('run.mat')``:

- ``S.data``: one field per column, each an N×1 double: ``t`` (s since the first sample),
  ``seq``, ``t_mono``, ``t_wall``, ``quality``, ``t_from_release`` (when the release is
  known) and every channel in SI (NaN = not read);
- ``S.units`` and ``S.long_names``: the same fields, each the column's unit / description;
- ``S.metadata``: the run's attributes (id, kind, vehicle, rig, drive, times, parameters,
  events as JSON text, free metadata), as in the NetCDF and Parquet exports.

MATLAB field names are letters, digits and ``_``, start with a letter, ≤ 63 characters:
a name that is not is written with its other characters as ``_`` (``x`` before a leading
digit or ``_``), and a name that then clashes gets ``_2``, ``_3``…
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from daq.store.loaded_run import FROM_RELEASE

if TYPE_CHECKING:
    from daq.store.loaded_run import LoadedRun

#: Longest MATLAB field name (``namelengthmax``).
MAX_FIELD = 63


def matlab_field(name: str, taken: set[str]) -> str:
    """``name`` as a MATLAB field name not in ``taken`` (which it is added to)."""
    field = re.sub(r"\W", "_", name, flags=re.ASCII)
    if not field or not field[0].isalpha():
        field = "x" + field
    field = field[:MAX_FIELD]
    base, n = field, 1
    while field in taken:
        n += 1
        tail = f"_{n}"
        field = base[: MAX_FIELD - len(tail)] + tail
    taken.add(field)
    return field


def mat_dict(run: LoadedRun) -> dict[str, dict[str, Any]]:
    """The variables of the ``.mat`` file: ``data``, ``units``, ``long_names``, ``metadata``."""
    table, infos = run.samples, run.columns
    columns: dict[str, np.ndarray] = {
        "t": table.t,
        "seq": table.seq,
        "t_mono": table.t_mono,
        "t_wall": table.t_wall,
        "quality": table.quality,
    }
    if run.release_t is not None:
        columns[FROM_RELEASE.name] = table.t - run.release_t
        infos = infos | {FROM_RELEASE.name: FROM_RELEASE}
    columns.update((name, table.channels[name]) for name in run.info.channel_names)
    data: dict[str, np.ndarray] = {}
    units: dict[str, str] = {}
    long_names: dict[str, str] = {}
    taken: set[str] = set()
    for name, values in columns.items():
        field = matlab_field(name, taken)
        data[field] = np.asarray(values, dtype=float).reshape(-1, 1)  # N×1 column
        units[field] = infos[name].units
        long_names[field] = infos[name].long_name
    taken = set()
    metadata = {matlab_field(k, taken): v for k, v in run.attributes().items()}
    return {"data": data, "units": units, "long_names": long_names, "metadata": metadata}


def write_mat(run: LoadedRun, path: str | Path) -> Path:
    """Write :func:`mat_dict` to ``path`` (MATLAB v5, compressed)."""
    from scipy.io import savemat

    path = Path(path)
    savemat(path, mat_dict(run), long_field_names=True, do_compression=True, oned_as="column")
    return path
