"""Checks of an import's samples against what the user said about them, made while the CSV
is parsed and before anything is written: the constant drive's sign against the direction
the record moves, a logged drive's peak against the rig file's limit, and the given release
and end instants against the record's time range."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from daq.sample import Sample
from daq.vocabulary import AXES, DRIVE_FIELD, LOGGED_DRIVE_CHANNEL

#: A departure from the first sample counts as motion beyond this many noise σ (the noise
#: from the second differences, which a smooth motion hardly has) ...
NOISE_MULTIPLE = 20.0
#: ... and beyond this fraction of the record's largest excursion from its first sample.
EXCURSION_FRACTION = 0.1


def first_motion(position: np.ndarray) -> tuple[int, float] | None:
    """Where the record first moves clearly away from its first sample: (sample index, its
    displacement), or None when it never does (a record at rest, or too short)."""
    x = np.asarray(position, dtype=float)
    x = x[np.isfinite(x)]
    if x.size < 3:
        return None
    excursion = x - x[0]
    largest = float(np.max(np.abs(excursion)))
    if largest == 0.0:
        return None
    second = np.diff(x, 2)
    noise = 1.4826 * float(np.median(np.abs(second - np.median(second)))) / math.sqrt(6)
    threshold = max(NOISE_MULTIPLE * noise, EXCURSION_FRACTION * largest)
    beyond = np.flatnonzero(np.abs(excursion) > threshold)
    if beyond.size == 0:
        return None
    k = int(beyond[0])
    return k, float(excursion[k])


def check_drive_direction(kind: str, parameters: dict[str, Any], position: np.ndarray) -> None:
    """A constant drive (``force_n``/``torque_nm``) pulls the way its sign says, so a body
    starting at rest moves that way first. Refuses (``ValueError`` naming the field) a drive
    whose sign disagrees with the record's first clear motion: estimation would fit it with
    an absurd inertia rather than fail. A drive logged per sample is not checked (an
    excitation such as a wave force may oppose the body's drift)."""
    if kind not in DRIVE_FIELD or parameters.get("drive_channel"):
        return
    name, unit = DRIVE_FIELD[kind]
    drive = parameters.get(name)
    moved = first_motion(position)
    if not isinstance(drive, int | float) or drive == 0 or moved is None:
        return
    k, displacement = moved
    if math.copysign(1.0, drive) == math.copysign(1.0, displacement):
        return
    way = "positive" if displacement > 0 else "negative"
    raise ValueError(
        f"{name}: {drive!r} is not allowed: the record first moves the {way} way "
        f"({displacement:+.4g} {AXES[kind].unit} from its first sample by sample "
        f"{k + 1}) and a {'positive' if drive > 0 else 'negative'} {name} pulls the other way; "
        f"give {-drive:g} {unit} (negative: a reverse run) or check the position column's sign"
    )


def check_logged_peak(
    kind: str, drive_column: str, values: Sequence[float], limit: tuple[str, float] | None
) -> None:
    """A drive logged per sample stays within the rig file's limit (``limit``: its name and
    value, SI); ``ValueError`` naming ``drive_column`` and the limit otherwise."""
    if limit is None or kind not in LOGGED_DRIVE_CHANNEL:
        return
    array = np.abs(np.asarray(values, dtype=float))
    peak = float(np.nanmax(array)) if array.size else 0.0
    name, value = limit
    if peak > value:
        unit = DRIVE_FIELD[kind][1]
        raise ValueError(
            f"drive_column: {drive_column!r} reaches {peak:g} {unit} (in SI), over the rig "
            f"limit {name} = {value:g} {unit}; allowed |drive| ≤ {value:g} {unit}"
        )


def window_times(
    times: Sequence[float],
    samples: Sequence[Sample],
    given: dict[str, float | None],
    *,
    early: bool,
) -> dict[str, float]:
    """The given release/end instants (s, on the CSV's ``t`` axis) as seconds since the
    stored run's first sample (its ``t_mono`` axis), checked against the recording.
    ``early``: the release may come before the first sample (a record that starts after
    the release, the body already moving), by at most the record's own length."""
    out: dict[str, float] = {}
    lo, hi = times[0], times[-1]
    for key, value in given.items():
        if value is None:
            continue
        low = lo - (hi - lo) if early and key == "release_time_s" else lo
        if not math.isfinite(value) or not low <= value <= hi:
            note = " (before the first sample: the record starts after the release)"
            raise ValueError(
                f"{key}: {value!r} is not allowed; use a time within [{low:g}, {hi:g}] s"
                + (note if low < lo else " (the file's t range)")
            )
        mono = [s.t_mono for s in samples]
        if value < lo:  # before the record: its time axis runs on back
            out[key] = value - lo
        else:
            out[key] = float(np.interp(value, times, mono)) - mono[0]
    if len(out) == 2 and not out["release_time_s"] < out["end_time_s"]:
        raise ValueError(
            f"end_time_s: {given['end_time_s']!r} is not allowed; use a time after "
            f"release_time_s ({given['release_time_s']!r})"
        )
    return out
