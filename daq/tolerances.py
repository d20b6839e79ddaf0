"""The rig file's ``[tolerances]``: declared tolerances ±a of the rig's constants, the Type B
sources of the uncertainty budget (``estimation.uncertainty.sources``, docs/uncertainty.md)."""

from __future__ import annotations

from typing import Any

from pydantic import BaseModel, ConfigDict, Field


def _tol(high: float, unit: str) -> Any:
    return Field(default=None, ge=0, le=high, allow_inf_nan=False, description=unit)


class Tolerances(BaseModel):
    """Declared tolerances ±a (half-widths, rectangular) of the rig's constants: the Type B
    sources of the uncertainty budget (``estimation.uncertainty.sources``, docs/uncertainty.md).
    A field left out is not declared."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    hung_mass_kg: float | None = _tol(1.0, "kg, each hung weight")
    g_m_s2: float | None = _tol(0.1, "m/s²")
    pulley_radius_m: float | None = _tol(0.1, "m")
    pulley_inertia_kg_m2: float | None = _tol(1.0, "kg·m²")
    spin_drum_radius_m: float | None = _tol(0.1, "m")
    spin_drum_inertia_kg_m2: float | None = _tol(1.0, "kg·m²")
    encoder_scale_rel: float | None = _tol(0.1, "relative")
    angle_scale_rel: float | None = _tol(0.1, "relative")
    thrust_calibration_rel: float | None = _tol(0.5, "relative")
    water_temperature_c: float | None = _tol(10.0, "°C")

    def declared(self) -> dict[str, float]:
        """The declared half-widths by name (the budget's ``tolerances``)."""
        return {k: v for k, v in self.model_dump().items() if v is not None}
