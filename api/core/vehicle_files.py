"""Where vehicle files are (the project's fixtures, then ``$RIG_VEHICLES_DIR``) and finding
one by name: what the 6-DOF simulation, the theory comparison and an estimate's theory job
share (no simulation, no request models, no numpy of its own)."""

from __future__ import annotations

import dataclasses
import os
import re
from pathlib import Path
from typing import Any

from estimation.vehicle.description import Vehicle6, VehicleError
from estimation.vehicle.vehicle_file import load_vehicle

#: The vehicles that come with the project.
FIXTURE_VEHICLES = Path(__file__).resolve().parents[2] / "fixtures" / "vehicles"
#: A directory of the lab's own vehicle files, searched after the fixtures.
VEHICLES_DIR_ENV = "RIG_VEHICLES_DIR"
_NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_.-]{0,99}$")


class VehicleNotFound(KeyError):
    """No vehicle file has this name."""

    def __str__(self) -> str:
        return str(self.args[0]) if self.args else "vehicle not found"


def vehicle_dirs() -> list[Path]:
    """The fixtures directory, then ``$RIG_VEHICLES_DIR`` when set."""
    dirs = [FIXTURE_VEHICLES]
    extra = os.environ.get(VEHICLES_DIR_ENV, "").strip()
    if extra:
        dirs.append(Path(extra).expanduser())
    return dirs


def vehicle_files() -> dict[str, Path]:
    """Vehicle name (file stem) → file; a later directory does not shadow an earlier one."""
    found: dict[str, Path] = {}
    for folder in vehicle_dirs():
        if folder.is_dir():
            for path in sorted(folder.glob("*.toml")):
                found.setdefault(path.stem, path)
    return found


def find_vehicle(name: str, *, allow_path: bool = False) -> Vehicle6:
    """The vehicle named ``name`` (a file stem, e.g. ``seed002-rov``); with ``allow_path``
    (the CLI, not the API) also a path to a ``.toml`` file."""
    files = vehicle_files()
    if _NAME.match(name) and name in files:
        return _load(files[name])
    if allow_path and name.endswith(".toml") and Path(name).is_file():
        return load_vehicle(name)
    known = ", ".join(files) or "none"
    raise VehicleNotFound(f"no vehicle named {name!r}; known: {known}")


def shown_file(path: Path) -> str:
    """Where a vehicle file is, without this machine's folders: ``fixtures/vehicles/x.toml``
    for the project's, ``$RIG_VEHICLES_DIR/x.toml`` for the lab's."""
    if path.parent == FIXTURE_VEHICLES:
        return f"fixtures/vehicles/{path.name}"
    return f"${VEHICLES_DIR_ENV}/{path.name}"


def _load(path: Path) -> Vehicle6:
    """A vehicle file, named in its errors and ``source`` as :func:`shown_file` says."""
    shown = shown_file(path)
    try:
        return dataclasses.replace(load_vehicle(path), source=shown)
    except VehicleError as err:
        raise VehicleError(shown, err.field, err.value, err.allowed) from None


def vehicle_summary(name: str, path: Path) -> dict[str, Any]:
    """One line of the vehicle list (a broken file is listed with its error); file names
    as :func:`shown_file` gives them (no absolute paths in API answers)."""
    try:
        v = _load(path)
    except VehicleError as err:
        return {"name": name, "file": shown_file(path), "error": str(err)}
    return {
        "name": name,
        "file": shown_file(path),
        "vehicle": v.name,
        "mass_kg": v.mass_kg,
        "thrusters": [t.name for t in v.thrusters],
        "notes": v.notes,
    }
