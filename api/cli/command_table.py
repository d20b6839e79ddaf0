"""The ``rig`` command table: every command's module, attribute and short help, so that
``rig --help`` lists them and a command's module is imported only when it runs. The run
kinds' commands are built from their registry entries (``daq.procedures.run_kinds``), which
:data:`RIG_KIND_COMMANDS` lists for the help without importing the registry (its request models
cost ~0.4 s of CPU per ``rig --help``); tests/api/test_cli_edges.py checks the two agree."""

from __future__ import annotations

from collections.abc import Mapping

#: The module holding the procedure commands: one per kind the rig runs (derived from its
#: registry entry, ``api.cli.procedures``) and ``rig sequence``.
PROCEDURES_MODULE = "api.cli.procedures"
#: The command of each kind the rig runs, in the registry's order, as :data:`OTHER_COMMANDS`
#: lists the others (``api.cli.procedures`` builds them from the registry entries).
RIG_KIND_COMMANDS: dict[str, tuple[str, str, str]] = {
    "tow": (
        PROCEDURES_MODULE,
        "tow",
        "Tow test: a weight over the pulley (or the thrusters) pulls the vehicle along...",
    ),
    "spin": (
        PROCEDURES_MODULE,
        "spin",
        "Spin test: constant torque about the vertical axis (weight on the drum, or...",
    ),
    "pendulum": (
        PROCEDURES_MODULE,
        "pendulum",
        "Pendulum free decay: pull the vehicle out on the pendulum, release, record...",
    ),
    "calibrate-thrusters": (
        PROCEDURES_MODULE,
        "calibrate_thrusters",
        "Thrust calibration: step the thrusters on the load cell and fit thrust vs...",
    ),
    "manual-thrust": (
        PROCEDURES_MODULE,
        "manual_thrust",
        "Manual thrust: hold one thruster at a command for a bounded time on the...",
    ),
}
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
        "api.cli.runs",
        "show",
        "Show one run: configuration, how it ended, events and results (id or unique...",
    ),
    "results": (
        "api.cli.results",
        "results",
        "List stored results, newest first, or compare two or more (--compare).",
    ),
    "annotate": (
        "api.cli.runs",
        "annotate",
        "Set a run's metadata: operator, water temperature, notes, tags, free keys.",
    ),
    "export": (
        "api.cli.runs",
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
COMMANDS: Mapping[str, tuple[str, str, str]] = RIG_KIND_COMMANDS | OTHER_COMMANDS


def records_runs(name: str, module: str) -> bool:
    """Commands that record or import runs take --operator --water-temp --notes --tag --meta
    (api.cli.metadata), added here once rather than per command: every procedure command
    (one per kind the rig runs, and sequences) and the import."""
    return module == PROCEDURES_MODULE or name == "import"
