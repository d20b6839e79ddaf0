"""Samples to blocks and back. A block is a batch of one run's samples stored as one row of
``sample_blocks``: each column a little-endian array (``seq`` int64, ``t_mono`` and
``t_wall`` float64 s, ``quality`` int64 flags, the channel values float64 channel after
channel in the run's channel order) and the stale channels of the samples that had any as
JSON. Reading a run concatenates the arrays of its blocks: no work per sample.

numpy is imported inside the functions: listing runs needs none.
"""

from __future__ import annotations

import json
import math
import struct
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from operator import itemgetter
from typing import TYPE_CHECKING, Any

from daq.sample import Sample
from daq.store.run_records import SampleTable

if TYPE_CHECKING:
    import numpy as np

NAN = math.nan

#: The columns of a ``sample_blocks`` row, in the order :meth:`Block.row` gives them.
BLOCK_COLUMNS = (
    "run_id", "first_seq", "last_seq", "sample_count", "level", "t_wall_max", "stale",
    "seq", "t_mono", "t_wall", "quality", "channel_values",
)  # fmt: skip

#: Most samples one block holds (≈ 7 MB at ten channels): a batch or a merge that would
#: hold more is stored as several blocks, so a window reads at most this much around it.
BLOCK_MAX_SAMPLES = 65_536


@dataclass(frozen=True)
class Block:
    """One block's samples as arrays, ``seq`` ascending and unique: ``values`` has one row
    per channel (run order), ``stale`` maps a sample's index in the block to its stale
    channel names (only samples that have some); ``level`` counts the merges it came
    from (fresh batches are 0, see :mod:`daq.store.samples`)."""

    seq: np.ndarray
    t_mono: np.ndarray
    t_wall: np.ndarray
    quality: np.ndarray
    values: np.ndarray
    stale: dict[int, tuple[str, ...]] = field(default_factory=dict)
    level: int = 0

    def __len__(self) -> int:
        return int(self.seq.shape[0])

    def take(self, keep: np.ndarray) -> Block:
        """The samples at the indices (ascending) or boolean mask ``keep``."""
        import numpy as np

        index = np.flatnonzero(keep) if keep.dtype == np.bool_ else keep
        stale: dict[int, tuple[str, ...]] = {}
        if self.stale:
            position = np.full(len(self), -1, dtype=np.int64)
            position[index] = np.arange(len(index))
            stale = {int(position[i]): n for i, n in self.stale.items() if position[i] >= 0}
        return Block(
            self.seq[index],
            self.t_mono[index],
            self.t_wall[index],
            self.quality[index],
            self.values[:, index],
            stale,
            self.level,
        )

    def from_seq(self, start_seq: int) -> Block:
        """The samples with ``seq ≥ start_seq``."""
        import numpy as np

        first = int(np.searchsorted(self.seq, start_seq))
        return self if first == 0 else self.take(np.arange(first, len(self)))

    def chunks(self) -> list[Block]:
        """This block cut into blocks of at most :data:`BLOCK_MAX_SAMPLES` samples."""
        import numpy as np

        size = BLOCK_MAX_SAMPLES
        if len(self) <= size:
            return [self]
        ends = range(size, len(self) + size, size)
        return [self.take(np.arange(end - size, min(end, len(self)))) for end in ends]

    def row(self, run_pk: int) -> tuple[Any, ...]:
        """The ``sample_blocks`` row of this block (at most :data:`BLOCK_MAX_SAMPLES`), its
        values in :data:`BLOCK_COLUMNS` order."""
        import numpy as np

        read = self.t_wall[~np.isnan(self.t_wall)]
        stale = {str(i): list(names) for i, names in self.stale.items()}
        return (
            run_pk,
            int(self.seq[0]),
            int(self.seq[-1]),
            len(self),
            self.level,
            float(read.max()) if read.size else None,
            json.dumps(stale) if stale else None,
            self.seq.astype("<i8").tobytes(),
            self.t_mono.astype("<f8").tobytes(),
            self.t_wall.astype("<f8").tobytes(),
            self.quality.astype("<i8").tobytes(),
            self.values.astype("<f8").tobytes(),
        )

    @classmethod
    def from_row(cls, row: Any, width: int) -> Block:
        """The block of a ``sample_blocks`` row (a run with ``width`` channels)."""
        import numpy as np

        count = int(row.sample_count)
        stale = json.loads(row.stale) if row.stale else {}
        return cls(
            np.frombuffer(row.seq, dtype="<i8"),
            np.frombuffer(row.t_mono, dtype="<f8"),
            np.frombuffer(row.t_wall, dtype="<f8"),
            np.frombuffer(row.quality, dtype="<i8"),
            np.frombuffer(row.channel_values, dtype="<f8").reshape(width, count),
            {int(i): tuple(names) for i, names in stale.items()},
            int(row.level),
        )

    @classmethod
    def joined(cls, blocks: Sequence[Block], level: int = 0) -> Block:
        """One block of the samples of ``blocks`` (seq unique across them), seq ascending."""
        import numpy as np

        seq = np.concatenate([b.seq for b in blocks])
        stale: dict[int, tuple[str, ...]] = {}
        offset = 0
        for b in blocks:
            stale.update((offset + i, names) for i, names in b.stale.items())
            offset += len(b)
        joined = cls(
            seq,
            np.concatenate([b.t_mono for b in blocks]),
            np.concatenate([b.t_wall for b in blocks]),
            np.concatenate([b.quality for b in blocks]),
            np.concatenate([b.values for b in blocks], axis=1),
            stale,
            level,
        )
        if len(seq) > 1 and not bool(np.all(seq[1:] > seq[:-1])):
            joined = joined.take(np.argsort(seq, kind="stable"))
        return joined


class SamplePacker:
    """Packs samples of one run (whose channel order is ``channel_names``) into blocks and
    reads blocks back as a :class:`SampleTable`."""

    def __init__(self, channel_names: Sequence[str]) -> None:
        self.channel_names = tuple(channel_names)
        self._struct = struct.Struct(f"<{len(self.channel_names)}d")
        self._getter = itemgetter(*self.channel_names) if self.channel_names else None

    @property
    def width(self) -> int:
        """How many channels the run records."""
        return len(self.channel_names)

    def values(self, channels: dict[str, float]) -> tuple[float, ...]:
        """Values in channel order; a channel the sample lacks is NaN."""
        if self._getter is None:
            return ()
        try:
            got = self._getter(channels)
        except KeyError:
            return tuple(channels.get(name, NAN) for name in self.channel_names)
        return (got,) if len(self.channel_names) == 1 else got

    def block(self, samples: Sequence[Sample]) -> Block:
        """The samples as one block, in seq order (raises ValueError naming a channel value
        that is not a number); repeated seqs are kept (the store refuses or drops them)."""
        import numpy as np

        pack, values = self._struct.pack, self.values
        try:
            packed = b"".join([pack(*values(s.channels)) for s in samples])
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
        count = len(samples)
        matrix = np.frombuffer(packed, dtype="<f8").reshape(count, self.width)
        block = Block(
            np.fromiter((s.seq for s in samples), dtype=np.int64, count=count),
            np.fromiter((s.t_mono for s in samples), dtype=np.float64, count=count),
            np.fromiter((s.t_wall for s in samples), dtype=np.float64, count=count),
            np.fromiter((s.quality for s in samples), dtype=np.int64, count=count),
            np.ascontiguousarray(matrix.T),
            {i: tuple(s.stale) for i, s in enumerate(samples) if s.stale},
        )
        seq = block.seq
        if count > 1 and not bool(np.all(seq[1:] >= seq[:-1])):
            block = block.take(np.argsort(seq, kind="stable"))
        return block

    def table(self, blocks: Iterable[Block], limit: int | None = None) -> SampleTable:
        """The samples of ``blocks`` (consecutive, seq ascending) as columns, at most
        ``limit`` of them."""
        import numpy as np

        parts = list(blocks)
        if not parts:
            empty = np.empty(0, dtype=np.float64)
            return SampleTable(
                seq=np.empty(0, dtype=np.int64),
                t_mono=empty,
                t_wall=empty.copy(),
                quality=np.empty(0, dtype=np.int64),
                channels={name: empty.copy() for name in self.channel_names},
            )
        count = sum(len(b) for b in parts) if limit is None else limit

        def column(arrays: list[np.ndarray], dtype: str) -> np.ndarray:
            return np.concatenate(arrays)[:count].astype(dtype, copy=False)

        stale: list[tuple[str, ...]] = [()] * min(count, sum(len(b) for b in parts))
        offset = 0
        for b in parts:
            for i, names in b.stale.items():
                if offset + i < len(stale):
                    stale[offset + i] = names
            offset += len(b)
        return SampleTable(
            seq=column([b.seq for b in parts], "=i8"),
            t_mono=column([b.t_mono for b in parts], "=f8"),
            t_wall=column([b.t_wall for b in parts], "=f8"),
            quality=column([b.quality for b in parts], "=i8"),
            channels={
                name: column([b.values[i] for b in parts], "=f8")
                for i, name in enumerate(self.channel_names)
            },
            stale=tuple(stale),
        )
