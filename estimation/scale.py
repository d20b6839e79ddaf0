"""Scale: Reynolds and Froude numbers of a run and dimensionless coefficients, so a
result can be compared with another tank, another scale or theory.

Conventions (stated because the literature varies):

* Re = U L / ν and Fr = U / √(g L), L the body length (ITTC 7.5-02-02-01 uses the
  waterline length; a submerged vehicle has none, so its overall length);
* added-mass coefficient C_a = m_a / (ρ ∇): the ratio Lamb calls k (½ for a sphere);
* added moment of inertia: C_I = I_a / (ρ ∇ L²) (Lamb's k' is I_a over the displaced
  fluid's own moment of inertia instead; ``estimation.theory`` reports that one for
  spheroids);
* drag coefficient from the quadratic damping: the model's K_Q |u| u = ½ ρ C_D A u²
  gives C_D = 2 K_Q / (ρ A_ref), A_ref the reference area the vehicle file declares
  (frontal area for surge, ∇^(2/3) when none is declared: say which).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from estimation.errors import FieldError, positive

#: Standard gravity, m/s² (used only when no local g is given).
STANDARD_GRAVITY = 9.80665


class ScaleError(FieldError):
    """A quantity that cannot be made dimensionless (one line: field, value, allowed)."""


def _positive(field_name: str, value: float) -> float:
    return positive(field_name, value, ScaleError)


def _finite(field_name: str, value: float) -> float:
    if not isinstance(value, (int, float)) or isinstance(value, bool) or not math.isfinite(value):
        raise ScaleError(field_name, value, "a finite number")
    return float(value)


@dataclass(frozen=True)
class FlowNumbers:
    """Re = U L / ν and Fr = U / √(g L) at ``speed_m_s`` for ``length_m``."""

    speed_m_s: float
    length_m: float
    reynolds: float
    froude: float


def reynolds_number(speed_m_s: float, length_m: float, kinematic_viscosity: float) -> float:
    """Re = U L / ν (U m/s, L m, ν m²/s); |U| is used, the sign of a reverse run dropped."""
    return (
        abs(_finite("speed_m_s", speed_m_s))
        * _positive("length_m", length_m)
        / _positive("kinematic_viscosity", kinematic_viscosity)
    )


def froude_number(speed_m_s: float, length_m: float, g: float = STANDARD_GRAVITY) -> float:
    """Fr = U / √(g L) (U m/s, L m, g m/s²)."""
    length = _positive("length_m", length_m)
    return abs(_finite("speed_m_s", speed_m_s)) / math.sqrt(_positive("g", g) * length)


def flow_numbers(
    speed_m_s: float, length_m: float, kinematic_viscosity: float, g: float = STANDARD_GRAVITY
) -> FlowNumbers:
    """Both numbers of one run (e.g. its steady speed)."""
    return FlowNumbers(
        speed_m_s=float(speed_m_s),
        length_m=float(length_m),
        reynolds=reynolds_number(speed_m_s, length_m, kinematic_viscosity),
        froude=froude_number(speed_m_s, length_m, g),
    )


def added_mass_coefficient(added_mass_kg: float, density: float, volume_m3: float) -> float:
    """C_a = m_a / (ρ ∇) (m_a kg, ρ kg/m³, ∇ m³): 0.5 for a sphere."""
    return _finite("added_mass_kg", added_mass_kg) / (
        _positive("density", density) * _positive("volume_m3", volume_m3)
    )


def added_inertia_coefficient(
    added_inertia_kg_m2: float, density: float, volume_m3: float, length_m: float
) -> float:
    """C_I = I_a / (ρ ∇ L²) (I_a kg·m², ρ kg/m³, ∇ m³, L m)."""
    return _finite("added_inertia_kg_m2", added_inertia_kg_m2) / (
        _positive("density", density)
        * _positive("volume_m3", volume_m3)
        * _positive("length_m", length_m) ** 2
    )


def drag_coefficient(quadratic_damping: float, density: float, reference_area_m2: float) -> float:
    """C_D = 2 K_Q / (ρ A_ref) (K_Q N·s²/m², ρ kg/m³, A_ref m²), from K_Q u² = ½ ρ C_D A u²."""
    return (
        2.0
        * _finite("quadratic_damping", quadratic_damping)
        / (_positive("density", density) * _positive("reference_area_m2", reference_area_m2))
    )
