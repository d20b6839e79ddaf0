"""Samples to database rows and back: channel values packed as one little-endian float64
BLOB per sample, in the run's channel order."""

from __future__ import annotations

import math
import struct
from collections.abc import Sequence
from operator import itemgetter
from typing import TYPE_CHECKING

from daq.sample import Sample

if TYPE_CHECKING:  # numpy is imported where samples are read: listing runs needs none
    import numpy as np

NAN = math.nan


class SamplePacker:
    """Packs samples of one run (whose channel order is ``channel_names``) into row tuples
    ``(run_pk, seq, t_mono, t_wall, quality, stale, channel_values)``."""

    def __init__(self, channel_names: Sequence[str]) -> None:
        self.channel_names = tuple(channel_names)
        self._struct = struct.Struct(f"<{len(self.channel_names)}d")
        self._getter = itemgetter(*self.channel_names) if self.channel_names else None

    def values(self, channels: dict[str, float]) -> tuple[float, ...]:
        """Values in channel order; a channel the sample lacks is NaN."""
        if self._getter is None:
            return ()
        try:
            got = self._getter(channels)
        except KeyError:
            return tuple(channels.get(name, NAN) for name in self.channel_names)
        return (got,) if len(self.channel_names) == 1 else got

    def rows(self, run_pk: int, samples: Sequence[Sample]) -> list[tuple]:
        """One row tuple per sample, ready for executemany."""
        pack = self._struct.pack
        values = self.values
        try:
            return [
                (
                    run_pk,
                    s.seq,
                    s.t_mono,
                    s.t_wall,
                    int(s.quality),
                    ",".join(s.stale) if s.stale else None,
                    pack(*values(s.channels)),
                )
                for s in samples
            ]
        except struct.error as exc:
            bad = next(
                (name, s.channels.get(name))
                for s in samples
                for name in self.channel_names
                if not isinstance(s.channels.get(name, 0.0), int | float)
            )
            raise ValueError(
                f"sample channel {bad[0]!r}: value {bad[1]!r} is not a number"
            ) from exc

    def unpack(self, blobs: list[bytes]) -> dict[str, np.ndarray]:
        """Column arrays name → float64 from the packed BLOBs of consecutive rows."""
        import numpy as np

        width = len(self.channel_names)
        if not blobs or width == 0:
            return {name: np.empty(0, dtype=np.float64) for name in self.channel_names}
        matrix = np.frombuffer(b"".join(blobs), dtype="<f8").reshape(len(blobs), width)
        return {
            name: np.ascontiguousarray(matrix[:, i], dtype=np.float64)
            for i, name in enumerate(self.channel_names)
        }
