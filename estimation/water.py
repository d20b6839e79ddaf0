"""Water properties for tow-tank work: density ρ and viscosity μ, ν of fresh water and sea
water at atmospheric pressure, from the temperature (and salinity).

ITTC 7.5-02-01-03 (2011) "Fresh Water and Seawater Properties" tabulates ρ and ν for
0–40 °C; it computed fresh water with IAPWS-95 (density) and the IAPWS 2008 formulation
for the viscosity of ordinary water, and sea water with the IAPWS-08 / TEOS-10 seawater
formulation and Sharqawy et al. (2010) for the viscosity. We implement the formulas, not
a copy of the table:

* fresh-water density: Tanaka et al. (2001), the CIPM formula for air-free water at
  101.325 kPa, which agrees with IAPWS-95 to ≤ 0.001 kg/m³ over 0–40 °C;
* fresh-water viscosity: IAPWS 2008 (Huber et al. 2009, eqs. 10–12, Tables 2–3; the
  critical enhancement μ₂ is 1 far from the critical point);
* sea-water density: the one-atmosphere international equation of state EOS-80
  (Millero & Poisson 1981, UNESCO 1981), from absolute salinity S_A via S_P = S_A·35/35.16504
  (Millero et al. 2008). It differs from the TEOS-10 values of the ITTC table by about
  0.05 kg/m³ (0.005 %) at 35 g/kg;
* sea-water viscosity: Sharqawy, Lienhard & Zubair (2010), eq. 22: μ_sw = μ_w (1 + A S + B S²),
  S in kg/kg.

At 10, 15 and 20 °C these give the ITTC table's fresh-water values to the table's last digit
(tests/estimation/theory/test_water.py).

References: ITTC Recommended Procedure 7.5-02-01-03 (2011); Tanaka M. et al. (2001)
Metrologia 38, 301–309; Huber M. L. et al. (2009) J. Phys. Chem. Ref. Data 38, 101–125
(IAPWS R12-08); Millero F. J. & Poisson A. (1981) Deep-Sea Res. 28A, 625–629; Millero F. J.
et al. (2008) Deep-Sea Res. I 55, 50–72; Sharqawy M. H. et al. (2010) Desalination and
Water Treatment 16, 354–380.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

#: Temperatures the formulas (and the ITTC table) cover, °C.
TEMPERATURE_RANGE_C = (0.0, 40.0)
#: Water temperature used when none is given (°C): ITTC's standard temperature for fresh water.
DEFAULT_WATER_TEMP_C = 15.0
#: Absolute salinities the sea-water formulas cover here, g/kg (fresh water is 0).
SALINITY_RANGE_G_KG = (0.0, 42.0)
#: Reference-composition seawater: S_A = 35.16504 g/kg at practical salinity 35.
_SA_PER_SP = 35.16504 / 35.0

# Tanaka et al. (2001), eq. 1 (air-free water, 101.325 kPa): a1…a5 in °C, °C, °C², °C, kg/m³.
_TANAKA = (-3.983035, 301.797, 522528.9, 69.34881, 999.974950)
# IAPWS 2008 viscosity: reference constants and Tables 2 and 3 (H_i, H_ij).
_T_STAR_K, _RHO_STAR, _MU_STAR = 647.096, 322.0, 1.0e-6
_H0 = (1.67752, 2.20462, 0.6366564, -0.241605)
_H = (
    (0.520094, 0.222531, -0.281378, 0.161913, -0.0325372, 0.0, 0.0),
    (0.0850895, 0.999115, -0.906851, 0.257399, 0.0, 0.0, 0.0),
    (-1.08374, 1.88797, -0.772479, 0.0, 0.0, 0.0, 0.0),
    (-0.289555, 1.26613, -0.489837, 0.0, 0.0698452, 0.0, -0.00435673),
    (0.0, 0.0, -0.25704, 0.0, 0.0, 0.00872102, 0.0),
    (0.0, 0.120573, 0.0, 0.0, 0.0, 0.0, -0.000593264),
)


class WaterError(ValueError):
    """A temperature or salinity outside the range the formulas cover (one line naming
    the field, the value and the range)."""

    def __init__(self, field_name: str, value: object, allowed: str) -> None:
        self.field, self.value, self.allowed = field_name, value, allowed
        super().__init__(f"{field_name}: got {value!r}, allowed: {allowed}")


@dataclass(frozen=True)
class WaterProperties:
    """Water at ``temperature_c`` (°C) and absolute salinity ``salinity_g_kg`` (g/kg; 0 =
    fresh water), atmospheric pressure: ``density`` ρ (kg/m³), ``dynamic_viscosity`` μ
    (Pa·s) and ``kinematic_viscosity`` ν = μ/ρ (m²/s); ``method`` names the formulas."""

    temperature_c: float
    salinity_g_kg: float
    density: float
    dynamic_viscosity: float
    kinematic_viscosity: float
    method: str

    def to_json(self) -> dict[str, float | str]:
        return {
            "temperature_c": self.temperature_c,
            "salinity_g_kg": self.salinity_g_kg,
            "density_kg_m3": self.density,
            "dynamic_viscosity_pa_s": self.dynamic_viscosity,
            "kinematic_viscosity_m2_s": self.kinematic_viscosity,
            "method": self.method,
        }


def _check(field_name: str, value: float, bounds: tuple[float, float], unit: str) -> float:
    low, high = bounds
    if not isinstance(value, (int, float)) or isinstance(value, bool) or not math.isfinite(value):
        raise WaterError(field_name, value, f"a number {low:g} … {high:g} {unit}")
    if not low <= value <= high:
        raise WaterError(field_name, value, f"{low:g} … {high:g} {unit}")
    return float(value)


def fresh_water_density(temperature_c: float) -> float:
    """ρ(t) of air-free fresh water at 101.325 kPa, kg/m³ (Tanaka et al. 2001, eq. 1):

    ρ = a5 · [1 − (t + a1)² (t + a2) / (a3 (t + a4))], t in °C.
    """
    t = _check("temperature_c", temperature_c, TEMPERATURE_RANGE_C, "°C")
    a1, a2, a3, a4, a5 = _TANAKA
    return a5 * (1.0 - (t + a1) ** 2 * (t + a2) / (a3 * (t + a4)))


def water_viscosity(temperature_c: float, density: float) -> float:
    """Dynamic viscosity μ of water, Pa·s (IAPWS 2008, Huber et al. 2009):

    μ/μ* = μ₀(T̄) · μ₁(T̄, ρ̄),  μ₀ = 100 √T̄ / Σᵢ Hᵢ/T̄ⁱ,
    μ₁ = exp[ρ̄ Σᵢ (1/T̄ − 1)ⁱ Σⱼ Hᵢⱼ (ρ̄ − 1)ʲ],
    T̄ = T/647.096 K, ρ̄ = ρ/322 kg/m³, μ* = 1 µPa·s (μ₂ = 1 outside the critical region).
    """
    t = _check("temperature_c", temperature_c, TEMPERATURE_RANGE_C, "°C")
    t_bar = (t + 273.15) / _T_STAR_K
    rho_bar = density / _RHO_STAR
    mu0 = 100.0 * math.sqrt(t_bar) / sum(h / t_bar**i for i, h in enumerate(_H0))
    inner = sum(
        (1.0 / t_bar - 1.0) ** i * sum(h * (rho_bar - 1.0) ** j for j, h in enumerate(row))
        for i, row in enumerate(_H)
    )
    return _MU_STAR * mu0 * math.exp(rho_bar * inner)


def _smow_density(t: float) -> float:
    """Standard Mean Ocean Water, kg/m³ (Bigg 1967, as used by EOS-80)."""
    return (
        999.842594
        + 6.793952e-2 * t
        - 9.095290e-3 * t**2
        + 1.001685e-4 * t**3
        - 1.120083e-6 * t**4
        + 6.536332e-9 * t**5
    )


def sea_water_density(temperature_c: float, salinity_g_kg: float) -> float:
    """ρ(S, t) at one atmosphere, kg/m³: EOS-80 (Millero & Poisson 1981),

    ρ = ρ_SMOW(t) + A(t)·S_P + B(t)·S_P^1.5 + C·S_P², with S_P = S_A · 35/35.16504.
    """
    t = _check("temperature_c", temperature_c, TEMPERATURE_RANGE_C, "°C")
    s_a = _check("salinity_g_kg", salinity_g_kg, SALINITY_RANGE_G_KG, "g/kg")
    s = s_a / _SA_PER_SP
    a = 8.24493e-1 - 4.0899e-3 * t + 7.6438e-5 * t**2 - 8.2467e-7 * t**3 + 5.3875e-9 * t**4
    b = -5.72466e-3 + 1.0227e-4 * t - 1.6546e-6 * t**2
    c = 4.8314e-4
    return _smow_density(t) + a * s + b * s**1.5 + c * s**2


def sea_water_viscosity(temperature_c: float, salinity_g_kg: float) -> float:
    """μ_sw = μ_w(t) · (1 + A S + B S²), Pa·s, S = S_A in kg/kg (Sharqawy et al. 2010,
    eq. 22): A = 1.541 + 1.998e-2 t − 9.52e-5 t², B = 7.974 − 7.561e-2 t + 4.724e-4 t²."""
    t = _check("temperature_c", temperature_c, TEMPERATURE_RANGE_C, "°C")
    s = _check("salinity_g_kg", salinity_g_kg, SALINITY_RANGE_G_KG, "g/kg") / 1000.0
    mu_w = water_viscosity(t, fresh_water_density(t))
    a = 1.541 + 1.998e-2 * t - 9.52e-5 * t**2
    b = 7.974 - 7.561e-2 * t + 4.724e-4 * t**2
    return mu_w * (1.0 + a * s + b * s**2)


def water_properties(temperature_c: float, salinity_g_kg: float = 0.0) -> WaterProperties:
    """ρ, μ and ν = μ/ρ at ``temperature_c`` (0–40 °C) and absolute salinity
    ``salinity_g_kg`` (0 = fresh water, 35.165 = standard sea water; ≤ 42 g/kg).

    >>> w = water_properties(15.0)
    >>> round(w.density, 2), f"{w.kinematic_viscosity:.4e}"
    (999.1, '1.1386e-06')
    """
    t = _check("temperature_c", temperature_c, TEMPERATURE_RANGE_C, "°C")
    s = _check("salinity_g_kg", salinity_g_kg, SALINITY_RANGE_G_KG, "g/kg")
    if s == 0.0:
        rho = fresh_water_density(t)
        mu = water_viscosity(t, rho)
        method = "fresh water: Tanaka et al. 2001 (density), IAPWS 2008 (viscosity)"
    else:
        rho = sea_water_density(t, s)
        mu = sea_water_viscosity(t, s)
        method = "sea water: EOS-80 (density), Sharqawy et al. 2010 (viscosity)"
    return WaterProperties(t, s, rho, mu, mu / rho, method)
