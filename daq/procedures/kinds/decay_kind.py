"""The free decay: a body released from an offset in one degree of freedom (imported only)."""

from __future__ import annotations

from daq.decay_import import DECAY, DECAY_IMPORT
from daq.procedures.kind_spec import KindSpec
from daq.vocabulary import RunKind

SPEC = KindSpec(
    kind=RunKind.DECAY,
    rank=50,
    label="free decay",
    help="Free decay: a body released from an offset in one degree of freedom "
    "(imported: rig import FILE --kind decay --dof heave).",
    estimator=DECAY,
    imports=DECAY_IMPORT,
)
