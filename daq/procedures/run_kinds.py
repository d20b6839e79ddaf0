"""The registry of run kinds: every module of ``daq.procedures.kinds`` is one kind (its
``SPEC``, a ``daq.procedures.kind_spec.KindSpec``), discovered here; every face looks it up.

An entry holds the kind's labels, its axis words (``daq.vocabulary.AXES``) and, for a kind
the rig runs, its request model (the API body, the ``rig`` options and the browser's start
form are derived from it; checked against the rig file it *is* the procedure's frozen
parameters) and the procedure that runs it; for a kind whose runs are estimated, its
estimator (``daq.estimators.Estimator``: loader, fit, methods, report); for a kind a CSV
may be imported as, its import rules (``daq.import_rules.ImportRules``); the operator acts its
procedure asks for (``daq.operator.SIMULATED_ACTS``). The HTTP routes, the
CLI commands, sequences, the job runner, the import and ``GET /api/kinds`` iterate or index
``KINDS`` (``RIG_KINDS``: those the rig runs) instead of branching on the kind.

Adding a kind the rig runs: write its procedure (a ``run_…`` coroutine), its request model
in ``daq.procedures.requests`` and one module in ``daq/procedures/kinds/`` with its ``SPEC``
(its ``rig`` command, with its help, and its HTTP route follow from it). A kind that is only
imported (a free decay) is one module with its estimator and import rules. This file does
not change.
"""

from __future__ import annotations

import functools
import importlib
import pkgutil
from typing import TYPE_CHECKING, Any

from pydantic import BaseModel

from daq.procedures import kinds
from daq.procedures.kind_spec import KindSpec

if TYPE_CHECKING:
    from daq.config import RigConfig


def discover_kinds() -> list[KindSpec]:
    """Every ``SPEC`` of the modules of ``daq.procedures.kinds``, by rank."""
    specs = []
    for module in pkgutil.iter_modules(kinds.__path__):
        spec = getattr(importlib.import_module(f"{kinds.__name__}.{module.name}"), "SPEC", None)
        if isinstance(spec, KindSpec):
            specs.append(spec)
    return sorted(specs, key=lambda s: s.rank)


#: Every run kind, by rank. ``KINDS["tow"]`` works too: a ``RunKind`` hashes as its string.
KINDS: dict[str, KindSpec] = {spec.kind: spec for spec in discover_kinds()}
#: The kinds the rig runs (a procedure, a request model, a route and a command).
RIG_KINDS: dict[str, KindSpec] = {k: s for k, s in KINDS.items() if s.request is not None}
#: The kinds a CSV may be imported as (``rig import --kind``, ``POST /api/runs/import``).
IMPORT_KINDS: dict[str, KindSpec] = {k: s for k, s in KINDS.items() if s.imports is not None}


@functools.cache
def import_fields() -> type[BaseModel]:
    """One model holding every importable kind's own import fields (a free decay's
    ``dof``): the ``rig import`` options and the HTTP import's query parameters. Which kind
    takes which is its import rule's check."""
    models = [s.imports.fields for s in IMPORT_KINDS.values() if s.imports and s.imports.fields]
    return type("ImportFields", (*models, BaseModel), {"__doc__": import_fields.__doc__})


def all_methods() -> tuple[str, ...]:
    """Every estimation method some kind's estimator takes (``rig estimate --method``,
    ``POST /api/jobs/estimation``), each once; which kind takes which is checked per run."""
    return tuple(
        dict.fromkeys(m for s in KINDS.values() if s.estimator for m in s.estimator.methods)
    )


def capabilities(rig: RigConfig) -> dict[str, dict[str, Any]]:
    """What ``rig`` can do, per run kind (``GET /api/rig`` → ``capabilities``)."""
    return {str(kind): spec.describe_capability(rig) for kind, spec in RIG_KINDS.items()}
