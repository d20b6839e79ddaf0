"""A measured tow/spin result made comparable: Re and Fr per run, the added mass (or added
moment of inertia) and the drag in dimensionless form with their expanded uncertainty, and
the added mass beside what theory predicts for the hull (``estimation.theory.compare``).

Conventions as ``estimation.scale`` states them: Re = U L/ν, Fr = U/√(gL) with U the run's
terminal speed (surge) or, for a spin, the tip speed ω·L/2 of a body of length L turning
about its centre; C_a = m_a/(ρ∇), C_I = I_a/(ρ∇L²), C_D = 2K_Q/(ρA_ref). The added part is
the fitted inertia minus the body's own (m, or I_zz about the CG). Its standard uncertainty
adds the body's declared tolerance to the inertia's u_c; the dimensionless coefficients add
the relative uncertainties of ρ (from the water temperature's tolerance), ∇ and L²:
u(C)/C = √((u_x/x)² + Σ (u_d/d)²). The vehicle-file tolerances are rectangular (u = a/√3)
with ν = ∞, so ν_eff = ν_eff(inertia)·(u/u_c)⁴ and U = t_0.975(ν_eff)·u.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from estimation import scale
from estimation.theory.compare import DEFAULT_BAND, compare_added_mass
from estimation.uncertainty.budget import coverage_factor
from estimation.uncertainty.text import plus_minus_u
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
    #: Standard uncertainties (u, not ±a) of body_inertia, volume_m3, length_m, and of the
    #: water density from the temperature's tolerance; 0 = not declared.
    u_body: float = 0.0
    u_volume: float = 0.0
    u_length: float = 0.0
    u_density: float = 0.0


def _expanded(u: float | None, u_c: float | None, dof: float | None) -> float | None:
    """U = k·u with ν_eff scaled from the coefficient's (the added sources have ν = ∞);
    None when the coefficient's own u is not known (then neither is U)."""
    if u is None or u_c is None or not (math.isfinite(u) and math.isfinite(u_c)):
        return None
    if dof is None or u_c <= 0 or u <= 0:
        return coverage_factor(math.inf) * u
    return coverage_factor(dof * (u / u_c) ** 4) * u


def _hypot(u: float | None, *others: float) -> float | None:
    """√(u² + Σ others²); None when ``u`` is not known."""
    return None if u is None or not math.isfinite(u) else math.hypot(u, *others)


def _per(u: float | None, divisor: float) -> float | None:
    return None if u is None else u / divisor


def measured_beside_theory(
    axis: str,
    coefficients: Mapping[str, tuple[float, float | None, float | None]],
    speeds: Mapping[str, float],
    water: WaterProperties,
    hull: HullScale,
    g: float,
    band: tuple[float, float] = DEFAULT_BAND,
) -> dict[str, Any]:
    """The document (module docstring). ``coefficients``: name → (value, u_c or None when
    not known, ν_eff or None for ∞) for inertia and quadratic_damping; ``speeds``: run id →
    terminal speed (m/s or rad/s). A U that rests on an unknown u_c is None."""
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
    inertia, u_c, dof = coefficients["inertia"]
    added = inertia - hull.body_inertia
    u_added = _hypot(u_c, hull.u_body)
    relative = {"rho": hull.u_density / rho, "volume": hull.u_volume / hull.volume_m3}
    if axis == "surge":
        divisor = rho * hull.volume_m3
        name, unit = "C_a = m_a / (ρ ∇)", "kg"
    else:
        divisor = rho * hull.volume_m3 * length**2
        name, unit = "C_I = I_a / (ρ ∇ L²)", "kg·m²"
        relative["length_squared"] = 2 * hull.u_length / length
    # u(C)/C = √((u_x/x)² + Σ(u_d/d)²), written for x: u(C)·divisor
    u_coef = _hypot(u_added, *(added * r for r in relative.values()))
    out: dict[str, Any] = {
        "water": water.to_json(),
        "length_m": length,
        "volume_m3": hull.volume_m3,
        "reference_area_m2": hull.reference_area_m2,
        "speed_convention": "terminal speed" if axis == "surge" else "tip speed ω·L/2",
        "runs": runs,
        "added": {
            "value": added,
            "standard_uncertainty": u_added,
            "expanded_uncertainty": _expanded(u_added, u_c, dof),
            "body": hull.body_inertia,
            "u_body": hull.u_body,
            "unit": unit,
        },
        "dimensionless": {
            name: {
                "value": added / divisor,
                "expanded_uncertainty": _per(_expanded(u_coef, u_c, dof), divisor),
                "relative_u_of_divisor": relative,
            }
        },
        "theory": None,
    }
    if axis == "surge" and "quadratic_damping" in coefficients:
        k_q, u_kq, dof_kq = coefficients["quadratic_damping"]
        area_divisor = rho * hull.reference_area_m2 / 2
        u_cd = _hypot(u_kq, abs(k_q) * hull.u_density / rho)
        out["dimensionless"]["C_D = 2 K_Q / (ρ A_ref)"] = {
            "value": k_q / area_divisor,
            "expanded_uncertainty": _per(_expanded(u_cd, u_kq, dof_kq), area_divisor),
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
        f"Added (fitted − body {a['body']:.4g} {a['unit']}): {a['value']:.4g}"
        f"{plus_minus_u(a['expanded_uncertainty'])} {a['unit']}.",
        "",
    ]
    for name, c in doc["dimensionless"].items():
        lines.append(f"- {name} = {c['value']:.4g}{plus_minus_u(c['expanded_uncertainty'])}")
    t = doc["theory"]
    if t is not None:
        flag = "" if t["plausible"] else "**FLAGGED** "
        lines += [
            "",
            f"Measured vs predicted added mass: {flag}ratio {t['ratio']:.3g} "
            f"(band {t['band'][0]:g} … {t['band'][1]:g}). {t['message']}",
        ]
    return "\n".join(lines) + "\n"
