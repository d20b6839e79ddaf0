"""Identified per-axis models plugged into a 6-DOF vehicle: ``I ν̇ + K_L ν + K_Q |ν| ν = τ``
on one axis gives its added mass (I − the body's), linear and quadratic damping, with σ."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import replace
from typing import Any

from estimation.vehicle.description import (
    DOFS,
    Vehicle6,
    VehicleError,
    checked_number,
    dof_index,
    is_finite,
    vehicle_source,
)

_ESTIMATE_SIGMA = {
    "inertia": "added_mass",
    "linear_damping": "linear_damping",
    "quadratic_damping": "quadratic_damping",
}


def apply_estimate(
    vehicle: Vehicle6,
    axis: str,
    inertia: float,
    linear: float,
    quadratic: float,
    sigma: Mapping[str, float] | None = None,
) -> Vehicle6:
    """Plug an identified per-axis model ``I ν̇ + K_L ν + K_Q |ν| ν = τ`` into the vehicle.

    ``inertia`` is the total (body + added): added_mass.<axis> = inertia − body mass
    (surge/sway/heave) or − body inertia about the origin (roll/pitch/yaw); a negative
    result is an error naming it. ``sigma`` may be keyed ``inertia``/``linear_damping``/
    ``quadratic_damping`` (σ of the added mass is σ of the total inertia: the body's is
    taken as exact) or by full coefficient name.
    """
    i = dof_index(vehicle, axis)
    body = vehicle.rigid_body_inertia(axis)
    where = vehicle_source(vehicle)
    inertia = checked_number(inertia, where, f"{axis} inertia")
    added = inertia - body
    if added < 0:
        unit = "kg" if i < 3 else "kg·m²"
        raise VehicleError(
            where,
            f"added_mass.{axis}",
            added,
            f"≥ 0: the identified inertia {inertia:g} {unit} is below the body's {body:g} {unit}",
        )
    changed = vehicle.with_coefficients(
        {
            f"added_mass.{axis}": added,
            f"linear_damping.{axis}": checked_number(linear, where, f"linear_damping.{axis}"),
            f"quadratic_damping.{axis}": checked_number(
                quadratic, where, f"quadratic_damping.{axis}"
            ),
        }
    )
    if not sigma:
        return changed
    new_sigma = dict(vehicle.sigma)
    for key, value in sigma.items():
        name = f"{_ESTIMATE_SIGMA[key]}.{axis}" if key in _ESTIMATE_SIGMA else key
        new_sigma[name] = value
    return replace(changed, sigma=new_sigma)


def apply_result_json(
    vehicle: Vehicle6, doc: Mapping[str, Any], source: str = "result"
) -> Vehicle6:
    """Plug a stored per-axis estimation result (``EstimationResult.to_json()``: its line,
    ``dof`` else ``axis``, and ``coefficients`` {inertia, linear_damping, quadratic_damping:
    {value, std}}) into the vehicle with :func:`apply_estimate`; σ comes along where the
    result has one. A result without ``quadratic_damping`` (a decay's or a swing's whose
    search found none) leaves the vehicle's value.

    A result giving the ``added_mass`` (a pendulum free decay's) gives it with the swing
    axis's damping: the inertia is the body's plus the added mass. A free decay's that was
    given the body's own inertia (``known.known_inertia``) identified the added part: the
    inertia is the sum."""
    # a tow imported as heave, a free decay: the line it moved along
    axis = (doc.get("dof") or doc.get("axis")) if isinstance(doc, Mapping) else None
    if axis not in DOFS:
        raise VehicleError(source, "axis", axis, "one of " + ", ".join(DOFS))
    coefficients = doc.get("coefficients")
    if not isinstance(coefficients, Mapping):
        raise VehicleError(source, "coefficients", coefficients, "a table of {value, std}")
    coefficients = dict(coefficients)
    added = coefficients.pop("added_mass", None)
    if isinstance(added, Mapping) and is_finite(added.get("value")):
        body = vehicle.rigid_body_inertia(axis)
        coefficients["inertia"] = {"value": body + added["value"], "std": added.get("std")}
    given = (doc.get("known") or {}).get("known_inertia")
    given = given.get("value") if isinstance(given, Mapping) else None
    identified = coefficients.get("inertia")
    if isinstance(identified, Mapping) and is_finite(given) and is_finite(identified.get("value")):
        total = given + float(identified["value"])
        coefficients["inertia"] = {"value": total, "std": identified.get("std")}
    coefficients.setdefault(
        "quadratic_damping", {"value": vehicle.coefficients()[f"quadratic_damping.{axis}"]}
    )
    values: dict[str, float] = {}
    sigma: dict[str, float] = {}
    for key in ("inertia", "linear_damping", "quadratic_damping"):
        entry = coefficients.get(key)
        value = entry.get("value") if isinstance(entry, Mapping) else None
        if not is_finite(value):
            raise VehicleError(source, f"coefficients.{key}.value", value, "a finite number")
        values[key] = float(value)
        std = entry.get("std")  # type: ignore[union-attr]
        if is_finite(std) and std >= 0:
            sigma[key] = float(std)
    try:
        return apply_estimate(
            vehicle,
            axis,
            values["inertia"],
            values["linear_damping"],
            values["quadratic_damping"],
            sigma,
        )
    except VehicleError as err:
        raise VehicleError(source, err.field, err.value, err.allowed) from None
