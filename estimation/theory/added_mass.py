"""Added mass of simple bodies in an unbounded ideal fluid (potential flow, no walls, no
free surface), per degree of freedom, in the body frame x (the length axis), y, z.

Ellipsoid with semi-axes a (x), b (y), c (z) — Lamb, *Hydrodynamics* (6th ed. 1932) §§ 114,
373; Lamb (1918) "The inertia-coefficients of an ellipsoid moving in fluid", ARC R&M 623:

    α₀ = abc ∫₀^∞ dλ / ((a² + λ) Δ),  Δ = √((a² + λ)(b² + λ)(c² + λ)),   β₀, γ₀ likewise,

(α₀ + β₀ + γ₀ = 2), written here with Carlson's symmetric integral,
α₀ = ⅔ abc R_D(b², c², a²). With the displaced mass m_f = ρ ⁴⁄₃π abc:

    m_a,x = α₀/(2 − α₀) · m_f        (and β₀, γ₀ for y, z)
    I_a,x = m_f/5 · (b² − c²)² (γ₀ − β₀) / (2(b² − c²) + (b² + c²)(β₀ − γ₀))
    (y, z by cyclic permutation a → b → c, α → β → γ).

Prolate spheroid (a > b = c, eccentricity e = √(1 − b²/a²)), Lamb §373 in closed form:

    α₀ = 2(1 − e²)/e³ · (½ ln((1 + e)/(1 − e)) − e),
    β₀ = 1/e² − (1 − e²)/(2e³) · ln((1 + e)/(1 − e)),
    k₁ = α₀/(2 − α₀) (axial), k₂ = β₀/(2 − β₀) (lateral),
    k' = e⁴ (β₀ − α₀) / ((2 − e²) [2e² − (2 − e²)(β₀ − α₀)]) (rotation about a transverse
    axis, as a fraction of the displaced fluid's moment of inertia m_f (a² + b²)/5).

Circular cylinder (radius r, length L along x): the two-dimensional strip value only,
ρπr² per unit length across the axis (Newman, *Marine Hydrodynamics* 1977, §4.13), so
m_a = ρπr²L laterally and ρπr²L³/12 about the transverse axes; no added inertia in roll.
Strip theory says nothing of the axial added mass (left out, ``None``) and ignores the
ends, so it overestimates the lateral values of a short cylinder. A rectangular box is
left out: we could not check DNV-RP-H103's Table A-1/A-2 coefficients against the source.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from estimation.errors import FieldError, positive

#: The six degrees of freedom, body frame (x the body's length axis).
DOFS: tuple[str, ...] = ("surge", "sway", "heave", "roll", "pitch", "yaw")
#: Below this relative difference two semi-axes are equal (no added roll inertia).
_EQUAL = 1e-9


class ShapeError(FieldError):
    """A dimension that describes no body (one line: field, value, allowed)."""


def _positive(field_name: str, value: float) -> float:
    return positive(field_name, value, ShapeError)


@dataclass(frozen=True)
class AddedMass:
    """Added mass per DOF: surge/sway/heave in kg, roll/pitch/yaw in kg·m² (about the
    body's centre), ``None`` where the method predicts nothing (the reason in ``notes``).

    ``coefficients`` are dimensionless per DOF: m_a/(ρ∇) for translation and, for rotation,
    I_a over the displaced fluid's own moment of inertia (Lamb's k'; ``None`` when that
    inertia is zero or unknown). ``displaced_volume_m3`` is the body's geometric volume.
    """

    shape: str
    density: float
    displaced_volume_m3: float
    values: dict[str, float | None]
    coefficients: dict[str, float | None]
    method: str
    notes: tuple[str, ...] = ()

    def to_json(self) -> dict:
        return {
            "shape": self.shape,
            "density_kg_m3": self.density,
            "displaced_volume_m3": self.displaced_volume_m3,
            "displaced_mass_kg": self.density * self.displaced_volume_m3,
            "added_mass": dict(self.values),
            "coefficients": dict(self.coefficients),
            "units": {d: ("kg" if i < 3 else "kg·m²") for i, d in enumerate(DOFS)},
            "method": self.method,
            "notes": list(self.notes),
        }


@dataclass(frozen=True)
class LambCoefficients:
    """Lamb's k₁ (axial), k₂ (lateral) and k' (rotational) of a prolate spheroid of
    length-to-diameter ratio ``aspect_ratio`` = a/b, with its eccentricity e."""

    aspect_ratio: float
    eccentricity: float
    k1: float
    k2: float
    k_rot: float


def ellipsoid_integrals(a: float, b: float, c: float) -> tuple[float, float, float]:
    """Lamb's α₀, β₀, γ₀ of the ellipsoid with semi-axes a, b, c (m): α₀ = ⅔ abc
    R_D(b², c², a²) etc. (Carlson's R_D; dimensionless, α₀ + β₀ + γ₀ = 2)."""
    a, b, c = (_positive(n, v) for n, v in (("a", a), ("b", b), ("c", c)))
    # Scale to the largest semi-axis: the integrals depend on the ratios only.
    s = max(a, b, c)
    a, b, c = a / s, b / s, c / s
    abc = a * b * c
    from scipy.special import elliprd  # a hull's added mass only: not at every import

    alpha = 2.0 / 3.0 * abc * float(elliprd(b * b, c * c, a * a))
    beta = 2.0 / 3.0 * abc * float(elliprd(a * a, c * c, b * b))
    gamma = 2.0 / 3.0 * abc * float(elliprd(a * a, b * b, c * c))
    return alpha, beta, gamma


def _rotational(p: float, q: float, int_p: float, int_q: float, mass: float) -> float:
    """I_a about the axis normal to semi-axes p and q (Lamb §373):
    m_f/5 · (p² − q²)² (int_q − int_p) / (2(p² − q²) + (p² + q²)(int_p − int_q))."""
    if abs(p - q) <= _EQUAL * max(p, q):
        return 0.0
    d2 = p * p - q * q
    return mass / 5.0 * d2 * d2 * (int_q - int_p) / (2.0 * d2 + (p * p + q * q) * (int_p - int_q))


def ellipsoid(length_m: float, width_m: float, height_m: float, density: float) -> AddedMass:
    """Added mass of an ellipsoid of overall length (x), width (y) and height (z), m, in
    fluid of ``density`` kg/m³ (Lamb §373; equations in the module docstring)."""
    a = _positive("length_m", length_m) / 2.0
    b = _positive("width_m", width_m) / 2.0
    c = _positive("height_m", height_m) / 2.0
    rho = _positive("density", density)
    volume = 4.0 / 3.0 * math.pi * a * b * c
    mass = rho * volume
    alpha, beta, gamma = ellipsoid_integrals(a, b, c)
    translation = [i / (2.0 - i) for i in (alpha, beta, gamma)]
    rotation = [
        _rotational(b, c, beta, gamma, mass),  # roll, about x
        _rotational(c, a, gamma, alpha, mass),  # pitch, about y
        _rotational(a, b, alpha, beta, mass),  # yaw, about z
    ]
    fluid_inertia = [
        mass * (b * b + c * c) / 5,
        mass * (c * c + a * a) / 5,
        mass * (a * a + b * b) / 5,
    ]
    values: dict[str, float | None] = {}
    coefficients: dict[str, float | None] = {}
    for dof, k in zip(DOFS[:3], translation, strict=True):
        values[dof], coefficients[dof] = k * mass, k
    for dof, i_a, i_f in zip(DOFS[3:], rotation, fluid_inertia, strict=True):
        values[dof], coefficients[dof] = i_a, i_a / i_f
    sphere = abs(a - b) <= _EQUAL * a and abs(a - c) <= _EQUAL * a
    shape = "sphere" if sphere else "spheroid" if abs(b - c) <= _EQUAL * b else "ellipsoid"
    return AddedMass(
        shape=shape,
        density=rho,
        displaced_volume_m3=volume,
        values=values,
        coefficients=coefficients,
        method="potential flow, unbounded fluid: Lamb (1932) §373 ellipsoid coefficients",
    )


def sphere(diameter_m: float, density: float) -> AddedMass:
    """A sphere: m_a = ½ ρ V on every translation, nothing in rotation (Lamb §92)."""
    d = _positive("diameter_m", diameter_m)
    return ellipsoid(d, d, d, density)


def spheroid(length_m: float, diameter_m: float, density: float) -> AddedMass:
    """A spheroid with its axis along x (prolate when longer than wide, oblate otherwise)."""
    return ellipsoid(length_m, diameter_m, diameter_m, density)


def prolate_spheroid_coefficients(aspect_ratio: float) -> LambCoefficients:
    """Lamb's k₁, k₂, k' of a prolate spheroid with a/b = ``aspect_ratio`` > 1, closed form
    (module docstring; Lamb §373). For a/b → 1 they tend to ½, ½, 0; for a/b → ∞ to 0, 1, 1."""
    ratio = _positive("aspect_ratio", aspect_ratio)
    if ratio <= 1.0:
        raise ShapeError("aspect_ratio", aspect_ratio, "> 1 (a prolate spheroid)")
    e = math.sqrt(1.0 - 1.0 / ratio**2)
    log_term = math.log((1.0 + e) / (1.0 - e))
    alpha = 2.0 * (1.0 - e * e) / e**3 * (0.5 * log_term - e)
    beta = 1.0 / (e * e) - (1.0 - e * e) / (2.0 * e**3) * log_term
    k1 = alpha / (2.0 - alpha)
    k2 = beta / (2.0 - beta)
    diff = beta - alpha
    k_rot = e**4 * diff / ((2.0 - e * e) * (2.0 * e * e - (2.0 - e * e) * diff))
    return LambCoefficients(ratio, e, k1, k2, k_rot)


def circular_cylinder_strip(length_m: float, diameter_m: float, density: float) -> AddedMass:
    """A circular cylinder along x by strip theory: ρπr²L in sway and heave, ρπr²L³/12 in
    pitch and yaw, 0 in roll; surge not predicted (``None``)."""
    length = _positive("length_m", length_m)
    r = _positive("diameter_m", diameter_m) / 2.0
    rho = _positive("density", density)
    volume = math.pi * r * r * length
    lateral = rho * volume
    about_transverse = lateral * length**2 / 12.0
    # Displaced fluid's own inertia about a transverse axis: m (3r² + L²)/12.
    fluid_transverse = rho * volume * (3 * r * r + length**2) / 12.0
    values: dict[str, float | None] = {
        "surge": None,
        "sway": lateral,
        "heave": lateral,
        "roll": 0.0,
        "pitch": about_transverse,
        "yaw": about_transverse,
    }
    coefficients: dict[str, float | None] = {
        "surge": None,
        "sway": 1.0,
        "heave": 1.0,
        "roll": None,
        "pitch": about_transverse / fluid_transverse,
        "yaw": about_transverse / fluid_transverse,
    }
    return AddedMass(
        shape="cylinder",
        density=rho,
        displaced_volume_m3=volume,
        values=values,
        coefficients=coefficients,
        method="potential flow, 2-D strip theory: ρπr² per unit length (no end correction)",
        notes=(
            "surge: strip theory predicts no axial added mass; give the hull as a spheroid "
            "of the same length and volume for one",
            "sway, heave, pitch, yaw: strip values without end effects (an overestimate for "
            f"a short cylinder; here L/D = {length / (2 * r):.3g})",
        ),
    )
