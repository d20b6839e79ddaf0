"""The ``rig`` command table: every command's module, attribute and short help, so that
``rig --help`` lists them and a command's module is imported only when it runs. The run
kinds' commands are read from their kind modules (``daq/procedures/kinds/*.py``: the
``command``, ``help`` and ``rank`` literals of each ``SPEC``) without importing them — the
registry's request models cost ~0.4 s of CPU per ``rig --help`` — so a new kind is listed
without an edit here; tests/api/test_cli_edges.py checks the table against the registry."""

from __future__ import annotations

import ast
import importlib.util
from collections.abc import Mapping
from pathlib import Path

#: The module holding the procedure commands: one per kind the rig runs (derived from its
#: registry entry, ``api.cli.procedures``) and ``rig sequence``.
PROCEDURES_MODULE = "api.cli.procedures"
#: The package whose modules are the run kinds (``daq.procedures.run_kinds`` discovers them).
KINDS_PACKAGE = "daq.procedures.kinds"


def _spec_literals(path: Path) -> dict[str, object] | None:
    """The literal keyword arguments of ``SPEC = KindSpec(...)`` in ``path`` (None when the
    module holds no ``SPEC``); a keyword whose value is not a literal is left out."""
    for node in ast.parse(path.read_text(encoding="utf-8"), str(path)).body:
        if (
            isinstance(node, ast.Assign)
            and any(isinstance(t, ast.Name) and t.id == "SPEC" for t in node.targets)
            and isinstance(node.value, ast.Call)
        ):
            out: dict[str, object] = {}
            for keyword in node.value.keywords:
                if keyword.arg is None:
                    continue
                try:
                    out[keyword.arg] = ast.literal_eval(keyword.value)
                except ValueError:  # a name or a call: present, not a literal
                    out[keyword.arg] = keyword.value
            return out
    return None


def kind_commands() -> dict[str, tuple[str, str, str]]:
    """The command of each kind the rig runs (its ``SPEC`` has a ``request`` and a
    ``command``), in rank order: name → (module, attribute, short help)."""
    import click

    spec = importlib.util.find_spec(KINDS_PACKAGE)
    folders = spec.submodule_search_locations if spec is not None else None
    found: list[tuple[int, str, str]] = []
    for folder in folders or ():
        for path in sorted(Path(folder).glob("*.py")):
            literals = _spec_literals(path)
            if literals is None or literals.get("request") is None:
                continue
            command, text, rank = (
                literals.get("command"),
                literals.get("help"),
                literals.get("rank"),
            )
            if isinstance(command, str) and isinstance(text, str) and isinstance(rank, int):
                found.append((rank, command, text))
    return {  # the short help as click shortens the command's own help
        name: (PROCEDURES_MODULE, name.replace("-", "_"),
               click.Command(name, help=about).get_short_help_str(80))
        for _, name, about in sorted(found)
    }  # fmt: skip


#: name → (module, attribute, its short help as ``rig --help`` lists it without importing
#: the module: ``get_short_help_str(80)``, checked by tests/api/test_cli_edges.py) of the
#: commands that are not a run kind's.
OTHER_COMMANDS: dict[str, tuple[str, str, str]] = {
    "sequence": (
        "api.cli.procedures",
        "sequence",
        "Run a sequence file (tows, spins, calibrations; repeats and rest time).",
    ),
    "campaign": (
        "api.cli.campaign",
        "campaign",
        "Measure until certain: the planner picks each test, stops at the target or...",
    ),
    "capabilities": (
        "api.cli.capabilities",
        "capabilities",
        "What the rig can do: each test (and drive), or why not; the safety channels...",
    ),
    "runs": ("api.cli.runs", "runs", "List stored runs, newest first."),
    "show": (
        "api.cli.show",
        "show",
        "Show one run: configuration, how it ended, events and results (id or unique...",
    ),
    "results": (
        "api.cli.results",
        "results",
        "List stored results, newest first, or compare two or more (--compare).",
    ),
    "annotate": (
        "api.cli.metadata",
        "annotate",
        "Set a run's metadata: operator, water (°C, g/kg), notes, tags, free keys.",
    ),
    "export": (
        "api.cli.export",
        "export",
        "Export a run with its units and metadata, in a format of --format.",
    ),
    "import": (
        "api.cli.imports",
        "import_",
        "Import a CSV (columns t [s] and position [m or rad]; more allowed); prints...",
    ),
    "import-calibration": (
        "api.cli.calibration",
        "import_calibration",
        "Import a thrust-stand calibration table (CSV: command, thrust, optional...",
    ),
    "calibrations": (
        "api.cli.calibration",
        "calibrations",
        "List thrust calibrations, measured (calibration runs) and imported tables,...",
    ),
    "thrust": (
        "api.cli.calibration",
        "thrust",
        "Thrust law of the stored calibration: the force ± σ at --command and...",
    ),
    "jobs": (
        "api.cli.jobs",
        "jobs",
        "List jobs stored in the database (every service's, across restarts), newest...",
    ),
    "queue": (
        "api.cli.jobs",
        "queue",
        "Show the rigs' queues: procedure jobs waiting for the rig, in the order they...",
    ),
    "estimate": (
        "api.cli.estimate",
        "estimate",
        "Fit (m + m_a) v̇ + K_L v + K_Q |v| v = τ to stored tow or spin runs (or α, β...",
    ),
    "crosscheck": (
        "api.cli.crosscheck",
        "crosscheck",
        "Estimate weight-driven and thruster-driven runs of one axis (or take two...",
    ),
    "warm-up": (
        "api.cli.warm_up",
        "warm_up",
        "Compile the estimator's kernels now (5-9 s of CPU once per install), so the...",
    ),
    "sim": (
        "api.cli.sim",
        "sim",
        "Run the simulated rig (plant, Modbus PLC, thruster controller) until Ctrl-C.",
    ),
    "serve": (
        "api.cli.serve",
        "serve",
        "Serve the HTTP API and the browser UI (binds 127.0.0.1 by default).",
    ),
    "token": (
        "api.cli.serve",
        "token",
        "Print the API's bearer token (created on first use; or set RIG_API_TOKEN).",
    ),
    "user": (
        "api.cli.people",
        "user",
        "Named users of the API: each with a token (shown once) and a role (operator...",
    ),
    "ack-estop": (
        "api.cli.people",
        "ack_estop",
        "Acknowledge an emergency stop: the rig takes starts again (named in the log).",
    ),
    "hold": (
        "api.cli.people",
        "hold",
        "Hold the rig for local work: remote starts by anyone else are refused (423).",
    ),
    "release": (
        "api.cli.people",
        "release",
        "Release the hold of the rig (its holder, or another operator with --override).",
    ),
    "sixdof": (
        "api.cli.sixdof",
        "sixdof",
        "Simulate VEHICLE (a name from fixtures/vehicles or $RIG_VEHICLES_DIR, or a...",
    ),
    "sensitivity": (
        "api.cli.analysis",
        "sensitivity",
        "Rank VEHICLE's coefficients (a name from fixtures/vehicles or...",
    ),
    "predict-added-mass": (
        "api.cli.theory",
        "predict_added_mass",
        "Predict VEHICLE's added mass per DOF from its [hull] (a name from...",
    ),
    "predict-uncertainty": (
        "api.cli.uncertainty",
        "predict_uncertainty",
        "Simulate SEQUENCE's weight-driven tows and spins with the current model and...",
    ),
    "water": (
        "api.cli.theory",
        "water",
        "Water density and viscosity at a temperature (ITTC 7.5-02-01-03 formulas).",
    ),
}


#: Every command, the kinds' first: name → (module, attribute, short help).
COMMANDS: Mapping[str, tuple[str, str, str]] = kind_commands() | OTHER_COMMANDS


def records_runs(name: str, module: str) -> bool:
    """Commands that record or import runs take --operator --water-temp --notes --tag --meta
    (api.cli.metadata), added here once rather than per command: every procedure command
    (one per kind the rig runs, and sequences) and the import."""
    return module == PROCEDURES_MODULE or name == "import"
