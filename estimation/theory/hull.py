"""A vehicle's hull as a primitive (the vehicle file's optional ``[hull]`` table) and its
predicted added mass per degree of freedom in an unbounded fluid.

``[hull]`` keys (lengths in m, the body's x axis is its length):

* ``shape`` = "sphere" (``diameter_m``) | "spheroid" (``length_m``, ``diameter_m``) |
  "ellipsoid" (``length_m``, ``width_m``, ``height_m``: the full axes along x, y, z) |
  "cylinder" (``length_m``, ``diameter_m``; strip theory, see ``added_mass``);
* ``displaced_volume_m3`` (optional): the vehicle's own ∇ when known; the prediction uses
  the primitive's volume and reports both, with a note when they differ by over 10 %;
* ``reference_area_m2`` (optional): A_ref for the drag coefficient; by default the
  primitive's frontal area (across x);
* ``notes``: where the dimensions come from.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, replace
from typing import Any

from estimation.theory import added_mass

SHAPES: dict[str, tuple[str, ...]] = {
    "sphere": ("diameter_m",),
    "spheroid": ("length_m", "diameter_m"),
    "ellipsoid": ("length_m", "width_m", "height_m"),
    "cylinder": ("length_m", "diameter_m"),
}
_OPTIONAL = ("displaced_volume_m3", "reference_area_m2", "notes")
#: Largest body dimension accepted, m (a tow-tank model, not a ship).
MAX_DIMENSION_M = 100.0
#: Declared and primitive volumes further apart than this are worth a note.
VOLUME_MISMATCH = 0.10


class HullError(ValueError):
    """A ``[hull]`` entry that cannot be used (one line: field, value, allowed)."""

    def __init__(self, field_name: str, value: object, allowed: str) -> None:
        self.field, self.value, self.allowed = field_name, value, allowed
        super().__init__(f"{field_name}: got {value!r}, allowed: {allowed}")


@dataclass(frozen=True)
class Hull:
    """A primitive hull: ``shape`` and its full dimensions along x (length), y (width)
    and z (height), m; a sphere has all three equal, a spheroid and a cylinder width =
    height = diameter. ``displaced_volume_m3``/``reference_area_m2`` as declared."""

    shape: str
    length_m: float
    width_m: float
    height_m: float
    displaced_volume_m3: float | None = None
    reference_area_m2: float | None = None
    notes: str = ""

    @property
    def frontal_area_m2(self) -> float:
        """Area across x: π/4 · width · height (an ellipse or a circle)."""
        return math.pi / 4.0 * self.width_m * self.height_m

    @property
    def primitive_volume_m3(self) -> float:
        """The primitive's geometric volume (π/6 · L W H for the ellipsoids, π/4 · D² L
        for the cylinder), m³."""
        if self.shape == "cylinder":
            return math.pi / 4.0 * self.width_m**2 * self.length_m
        return math.pi / 6.0 * self.length_m * self.width_m * self.height_m

    def to_json(self) -> dict[str, Any]:
        return {
            "shape": self.shape,
            "length_m": self.length_m,
            "width_m": self.width_m,
            "height_m": self.height_m,
            "primitive_volume_m3": self.primitive_volume_m3,
            "displaced_volume_m3": self.displaced_volume_m3,
            "reference_area_m2": self.reference_area_m2 or self.frontal_area_m2,
            "reference_area_declared": self.reference_area_m2 is not None,
            "notes": self.notes,
        }


def _dimension(table: Mapping[str, Any], key: str, limit: float, unit: str) -> float:
    value = table.get(key)
    if (
        not isinstance(value, (int, float))
        or isinstance(value, bool)
        or not math.isfinite(value)
        or not 0 < value <= limit
    ):
        raise HullError(f"hull.{key}", value, f"0 < {key} ≤ {limit:g} {unit}")
    return float(value)


def parse_hull(table: object) -> Hull:
    """A ``Hull`` from the vehicle file's ``[hull]`` table (HullError naming the key)."""
    if not isinstance(table, Mapping):
        raise HullError("[hull]", table, "a table with shape and its dimensions")
    shape = table.get("shape")
    if shape not in SHAPES:
        raise HullError("hull.shape", shape, " | ".join(f'"{s}"' for s in SHAPES))
    needed = SHAPES[shape]
    for key in table:
        if key != "shape" and key not in needed and key not in _OPTIONAL:
            allowed = ", ".join(("shape", *needed, *_OPTIONAL))
            raise HullError(f"hull.{key}", table[key], f"for shape {shape!r}: keys {allowed}")
    dims = {key: _dimension(table, key, MAX_DIMENSION_M, "m") for key in needed}
    if shape == "sphere":
        length = width = height = dims["diameter_m"]
    elif shape == "ellipsoid":
        length, width, height = dims["length_m"], dims["width_m"], dims["height_m"]
    else:
        length, width = dims["length_m"], dims["diameter_m"]
        height = width
    volume = (
        _dimension(table, "displaced_volume_m3", 1e4, "m³")
        if "displaced_volume_m3" in table
        else None
    )
    area = (
        _dimension(table, "reference_area_m2", 1e4, "m²") if "reference_area_m2" in table else None
    )
    notes = table.get("notes", "")
    if not isinstance(notes, str):
        raise HullError("hull.notes", notes, "a string")
    return Hull(shape, length, width, height, volume, area, notes)


@dataclass(frozen=True)
class HullPrediction:
    """The hull, the water density used and the added mass per DOF (``added_mass``)."""

    hull: Hull
    added_mass: added_mass.AddedMass

    def to_json(self) -> dict[str, Any]:
        return {"hull": self.hull.to_json(), **self.added_mass.to_json()}


def predict_added_mass(hull: Hull, density: float) -> HullPrediction:
    """Added mass per DOF of ``hull`` in an unbounded fluid of ``density`` kg/m³ (no walls,
    no free surface: ``estimation.theory.tank`` says how far the tank is from that)."""
    if hull.shape == "cylinder":
        result = added_mass.circular_cylinder_strip(hull.length_m, hull.width_m, density)
    else:
        result = added_mass.ellipsoid(hull.length_m, hull.width_m, hull.height_m, density)
        result = replace(result, shape=hull.shape)
    declared = hull.displaced_volume_m3
    if declared is not None:
        off = result.displaced_volume_m3 / declared - 1.0
        if abs(off) > VOLUME_MISMATCH:
            note = (
                f"the {hull.shape}'s volume {result.displaced_volume_m3:.4g} m³ is "
                f"{100 * off:+.0f} % of the declared displaced volume {declared:.4g} m³: "
                "its dimensions do not describe this vehicle well"
            )
            result = replace(result, notes=(*result.notes, note))
    return HullPrediction(hull, result)
