"""A measured tow/spin result made comparable: Re and Fr per run, the added mass (or added
moment of inertia) and the drag in dimensionless form with their expanded uncertainty, and
the added mass beside what theory predicts for the hull (``estimation.theory.compare``).

Conventions as ``estimation.scale`` states them: Re = U L/ν, Fr = U/√(gL) with U the run's
terminal speed (surge) or, for a spin, the tip speed ω·L/2 of a body of length L turning
about its centre; C_a = m_a/(ρ∇), C_I = I_a/(ρ∇L²), C_D = 2K_Q/(ρA_ref). The added part is
the fitted inertia minus the body's own (m, or I_zz about the CG); its U is the inertia's
(the body's own is taken as known). Both coefficients are linear in the measured value,
so their U is the measured U over the same divisor.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from estimation import scale
from estimation.theory.compare import DEFAULT_BAND, compare_added_mass
from estimation.water import WaterProperties


@dataclass(frozen=True)
class HullScale:
    """What the vehicle file says of the body: length L (m), displaced volume ∇ (m³),
    reference area (m²), its own inertia on the axis (kg or kg·m²), and the added mass
    theory predicts on the axis (None: no prediction)."""

    length_m: float
    volume_m3: float
    reference_area_m2: float
    body_inertia: float
    predicted_added: float | None


def measured_beside_theory(
    axis: str,
    coefficients: Mapping[str, tuple[float, float]],
    speeds: Mapping[str, float],
    water: WaterProperties,
    hull: HullScale,
    g: float,
    band: tuple[float, float] = DEFAULT_BAND,
) -> dict[str, Any]:
    """The document (module docstring). ``coefficients``: name → (value, U) for inertia and
    quadratic_damping; ``speeds``: run id → terminal speed (m/s or rad/s)."""
    rho, nu = water.density, water.kinematic_viscosity
    length = hull.length_m
    runs = {}
    for run_id, speed in speeds.items():
        u = speed if axis == "surge" else speed * length / 2
        runs[run_id] = {
            "speed_m_s": u,
            "reynolds": scale.reynolds_number(u, length, nu),
            "froude": scale.froude_number(u, length, g),
        }
    inertia, u_inertia = coefficients["inertia"]
    added = inertia - hull.body_inertia
    if axis == "surge":
        divisor = rho * hull.volume_m3
        added_doc = {"name": "C_a = m_a / (ρ ∇)", "unit": "kg"}
    else:
        divisor = rho * hull.volume_m3 * length**2
        added_doc = {"name": "C_I = I_a / (ρ ∇ L²)", "unit": "kg·m²"}
    out: dict[str, Any] = {
        "water": water.to_json(),
        "length_m": length,
        "volume_m3": hull.volume_m3,
        "reference_area_m2": hull.reference_area_m2,
        "speed_convention": "terminal speed" if axis == "surge" else "tip speed ω·L/2",
        "runs": runs,
        "added": {
            "value": added,
            "expanded_uncertainty": u_inertia,
            "body": hull.body_inertia,
            "unit": added_doc["unit"],
        },
        "dimensionless": {
            added_doc["name"]: {
                "value": added / divisor,
                "expanded_uncertainty": u_inertia / divisor,
            }
        },
        "theory": None,
    }
    if axis == "surge" and "quadratic_damping" in coefficients:
        k_q, u_kq = coefficients["quadratic_damping"]
        area_divisor = rho * hull.reference_area_m2 / 2
        out["dimensionless"]["C_D = 2 K_Q / (ρ A_ref)"] = {
            "value": k_q / area_divisor,
            "expanded_uncertainty": u_kq / area_divisor,
        }
    if hull.predicted_added is not None and hull.predicted_added > 0:
        out["theory"] = compare_added_mass(added, hull.predicted_added, band).to_json()
    return out


def theory_markdown(doc: Mapping[str, Any]) -> str:
    """## Scale and theory: water, Re/Fr per run, dimensionless coefficients, measured vs
    predicted added mass with its flag."""
    w = doc["water"]
    lines = [
        "## Scale and theory",
        "",
        f"Water {w['temperature_c']:g} °C: ρ = {w['density_kg_m3']:.2f} kg/m³, "
        f"ν = {w['kinematic_viscosity_m2_s']:.4e} m²/s; L = {doc['length_m']:g} m, "
        f"∇ = {doc['volume_m3']:.4g} m³ (Re, Fr at the {doc['speed_convention']}).",
        "",
        "| run | U (m/s) | Re | Fr |",
        "|---|---|---|---|",
    ]
    for run_id, r in doc["runs"].items():
        lines.append(
            f"| {run_id[:8]} | {r['speed_m_s']:.3g} | {r['reynolds']:.3g} | {r['froude']:.3g} |"
        )
    a = doc["added"]
    lines += [
        "",
        f"Added (fitted − body {a['body']:.4g} {a['unit']}): {a['value']:.4g} ± "
        f"{a['expanded_uncertainty']:.2g} {a['unit']}.",
        "",
    ]
    for name, c in doc["dimensionless"].items():
        lines.append(f"- {name} = {c['value']:.4g} ± {c['expanded_uncertainty']:.2g}")
    t = doc["theory"]
    if t is not None:
        flag = "" if t["plausible"] else "**FLAGGED** "
        lines += [
            "",
            f"Measured vs predicted added mass: {flag}ratio {t['ratio']:.3g} "
            f"(band {t['band'][0]:g} … {t['band'][1]:g}). {t['message']}",
        ]
    return "\n".join(lines) + "\n"
