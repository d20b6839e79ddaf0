"""The 6-DOF model: seed 002's B matrix, steady states, energy, restoring, kinematics."""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from estimation.vehicle.apply_estimates import apply_estimate
from estimation.vehicle.description import COEFFICIENT_NAMES, DOFS, VehicleError
from estimation.vehicle.dynamics import (
    SingularAttitude,
    allocation_matrix,
    mass_matrix,
    resisting_force,
    state_derivative,
)
from estimation.vehicle.simulation import simulate, steady_state
from estimation.vehicle.vehicle_file import load_vehicle, parse_vehicle

VEHICLES = Path(__file__).resolve().parents[3] / "fixtures" / "vehicles"
ZERO_DAMPING = {f"{k}.{d}": 0.0 for k in ("linear_damping", "quadratic_damping") for d in DOFS}


@pytest.fixture(scope="module")
def rov():
    return load_vehicle(VEHICLES / "seed002-rov.toml")


@pytest.fixture(scope="module")
def benbam():
    return load_vehicle(VEHICLES / "benbam.toml")


def test_allocation_reproduces_seed002_b_matrix(rov):
    """Seed 002 §6: B rows = 2.4336·[d; ρ × d]/(m + m_ad) or /I (its frame has z up; the
    printed rotational rows are 100× too large)."""
    to_thesis = np.diag([1, -1, -1, 1, -1, -1])  # y port, z up
    total = np.array([rov.total_inertia(d) for d in DOFS])
    b = to_thesis @ allocation_matrix(rov) / total[:, None]
    printed = np.array(
        [
            [0.0199, 0.0199, -0.0199, -0.0199, -0.0073, -0.0073, 0.0073, 0.0073],
            [-0.0114, 0.0114, 0.0114, -0.0114, -0.0059, 0.0059, 0.0059, -0.0059],
            [0, 0, 0, 0, 0.0085, 0.0085, 0.0085, 0.0085],
        ]
    )
    np.testing.assert_allclose(b[:3], printed, atol=0.51e-4)
    printed_rot = np.array(
        [
            [0, 0, 0, 0, 1.7899, -1.7899, -1.7899, 1.7899],
            [0, 0, 0, 0, -3.1287, -3.1287, 3.1287, 3.1287],
            [-8.174, 8.174, -8.174, 8.174, 0, 0, 0, 0],
        ]
    )
    np.testing.assert_allclose(b[3:], printed_rot / 100, atol=0.6e-4 / 100)  # printed digits
    # totals of the rotational axes are the thesis's I = J + J_ad
    np.testing.assert_allclose(total[3:], [17.8011, 10.1836, 7.9394], rtol=1e-9)


def test_fast_right_hand_side_matches_matrix_form(rov):
    """The unrolled simulator equals M⁻¹(τ − Cν − Dν − g) and J(η)ν at a random state,
    with a CG offset, a CB offset and net buoyancy so every term is exercised."""
    from estimation.vehicle.simulation import _rhs_factory

    rng = np.random.default_rng(3)
    veh = replace(rov, cg_m=(0.01, -0.02, 0.03), cb_m=(-0.01, 0.01, -0.05), buoyancy_n=420.0)
    veh = veh.with_coefficients({"quadratic_damping.sway": 30.0})
    for _ in range(5):
        eta = rng.normal(size=6) * 0.5
        nu = rng.normal(size=6)
        tau = rng.normal(size=6) * 10
        rhs = _rhs_factory(veh, tau, None)
        fast = np.array(rhs(0.0, np.concatenate([eta, nu])))
        eta_dot, nu_dot = state_derivative(veh, eta, nu, tau)
        np.testing.assert_allclose(fast, np.concatenate([eta_dot, nu_dot]), rtol=1e-10, atol=1e-12)


def test_steady_surge_speed_solves_damping_balance(benbam):
    """Both thrusters at 0.3 → F = 24 N along x: K_L u + K_Q u² = F at steady state."""
    force = 2 * 40.0 * 0.3
    traj = simulate(benbam, 30.0, commands=[0.3, 0.3])
    kl, kq = benbam.linear_damping[0], benbam.quadratic_damping[0]
    expected = (-kl + math.sqrt(kl**2 + 4 * kq * force)) / (2 * kq)
    assert traj.nu[-1, 0] == pytest.approx(expected, rel=1e-4)
    assert np.max(np.abs(traj.nu[-1, 1:])) < 1e-9
    assert steady_state(traj).settled
    # reverse thrust gives the mirror speed
    back = simulate(benbam, 30.0, force=[-force, 0, 0, 0, 0, 0])
    assert back.nu[-1, 0] == pytest.approx(-expected, rel=1e-4)


def test_kinetic_energy_conserved_without_damping(rov):
    """D = 0, g = 0 (CG = CB, W = B), spinning and translating: ½νᵀMν stays constant
    although ν itself changes (Coriolis and Munk terms do no work)."""
    veh = replace(rov.with_coefficients(ZERO_DAMPING), cg_m=(0.02, -0.01, 0.03))
    veh = replace(veh, cb_m=veh.cg_m, buoyancy_n=veh.weight_n)
    nu0 = np.array([0.3, -0.2, 0.1, 0.4, -0.3, 0.5])
    traj = simulate(veh, 20.0, nu0=nu0)
    m = mass_matrix(veh)
    energy = 0.5 * np.einsum("ni,ij,nj->n", traj.nu, m, traj.nu)
    assert np.max(np.abs(energy / energy[0] - 1)) < 1e-6
    assert np.max(np.abs(traj.nu - nu0)) > 0.05  # the state really moved


def test_roll_restoring_period(rov):
    """CB 5 cm above the CG: roll oscillates about 0 with T = 2π √((I_xx + K_ṗ)/(W·BG))."""
    bg = 0.05
    veh = replace(rov, cb_m=(0.0, 0.0, -bg))  # z down: above
    free = veh.with_coefficients({"linear_damping.roll": 0.0, "quadratic_damping.roll": 0.0})
    traj = simulate(free, 30.0, eta0=[0, 0, 0, 0.02, 0, 0], dt=0.001)
    phi = traj.eta[:, 3]
    ups = np.nonzero((phi[:-1] < 0) & (phi[1:] >= 0))[0]
    frac = -phi[ups] / (phi[ups + 1] - phi[ups])
    crossings = traj.t[ups] + frac * 0.001
    period = np.mean(np.diff(crossings))
    expected = 2 * math.pi * math.sqrt(free.total_inertia("roll") / (free.weight_n * bg))
    assert len(crossings) >= 2
    assert period == pytest.approx(expected, rel=2e-3)
    damped = simulate(veh, 60.0, eta0=[0, 0, 0, 0.2, 0, 0])
    assert abs(damped.eta[-1, 3]) < 0.2 * 0.5
    assert np.max(np.abs(damped.eta[:, 3])) <= 0.2 + 1e-9


def test_constant_yaw_rate_and_surge_draw_a_circle(benbam):
    """Hold ν = (u, 0, 0, 0, 0, r) with the force that balances C(ν)ν + D(ν)ν: the track
    is a circle of radius u/r."""
    u, r = 0.4, 0.25
    nu0 = [u, 0, 0, 0, 0, r]
    hold = resisting_force(benbam, np.zeros(6), nu0)
    traj = simulate(benbam, 2 * math.pi / r, force=hold, nu0=nu0, dt=0.05)
    np.testing.assert_allclose(traj.nu, np.tile(nu0, (len(traj.t), 1)), atol=1e-8)
    x, y = traj.eta[:, 0], traj.eta[:, 1]
    radius = np.hypot(x, y - u / r)  # centre at (0, u/r): r > 0 turns to starboard
    np.testing.assert_allclose(radius, u / r, rtol=1e-6)
    assert np.ptp(y) == pytest.approx(2 * u / r, rel=1e-3)


def test_pure_yaw_torque_from_thrusters(rov):
    """Seed 002 virtual input w_φ = −u₁ + u₂ − u₃ + u₄: only yaw rate at steady state."""
    s = 0.5
    traj = simulate(rov, 40.0, commands=[-s, s, -s, s, 0, 0, 0, 0])
    end = traj.nu[-1]
    torque = allocation_matrix(rov)[5] @ np.array([-s, s, -s, s, 0, 0, 0, 0])
    kl, kq = rov.linear_damping[5], rov.quadratic_damping[5]
    r_expected = math.copysign((-kl + math.sqrt(kl**2 + 4 * kq * abs(torque))) / (2 * kq), torque)
    assert end[5] == pytest.approx(r_expected, rel=1e-4)
    assert torque < 0  # positive w_φ turns positively about the thesis's z-up axis
    assert np.max(np.abs(traj.nu[:, :5])) < 1e-9


def test_heave_thrust_rises_in_z_up_frame(rov):
    """All four upper thrusters forward: the ROV rises (z decreases, NED)."""
    traj = simulate(rov, 5.0, commands=[0, 0, 0, 0, 0.5, 0.5, 0.5, 0.5])
    assert traj.nu[-1, 2] < 0
    assert np.max(np.abs(traj.nu[-1, [0, 1, 3, 4, 5]])) < 1e-9


def test_apply_estimate_sets_added_mass(benbam):
    veh = apply_estimate(benbam, "surge", 150.0, 21.0, 230.0, sigma={"inertia": 3.0})
    assert veh.coefficients()["added_mass.surge"] == pytest.approx(120.0)
    assert veh.coefficients()["quadratic_damping.surge"] == 230.0
    assert veh.sigma["added_mass.surge"] == 3.0
    assert veh.total_inertia("surge") == pytest.approx(150.0)
    with pytest.raises(VehicleError, match=r"added_mass\.yaw.*below the body"):
        apply_estimate(benbam, "yaw", 1.0, 0.1, 1.0)


def test_coefficients_round_trip(rov):
    coeffs = rov.coefficients()
    assert set(coeffs) == set(COEFFICIENT_NAMES) and len(coeffs) == 18
    changed = rov.with_coefficients({"linear_damping.yaw": 2.5})
    assert changed.coefficients()["linear_damping.yaw"] == 2.5
    assert changed.coefficients()["linear_damping.roll"] == coeffs["linear_damping.roll"]
    with pytest.raises(ValueError, match=r"coefficient.*'damping\.yaw'"):
        rov.with_coefficients({"damping.yaw": 1.0})
    with pytest.raises(VehicleError, match=r"quadratic_damping\.roll.*-1"):
        rov.with_coefficients({"quadratic_damping.roll": -1.0})


def _benbam_data() -> dict:
    import tomllib

    return tomllib.loads((VEHICLES / "benbam.toml").read_text(encoding="utf-8"))


def test_file_errors_name_file_field_value():
    data = _benbam_data()
    data["vehicle"]["mass_kg"] = -3.0
    with pytest.raises(VehicleError, match=r"x\.toml: mass_kg: got -3\.0, allowed: 0 < m"):
        parse_vehicle(data, "x.toml")
    data = _benbam_data()
    data["thrusters"][1]["direction"] = [1.0, 1.0, 0.0]
    with pytest.raises(VehicleError, match=r"thrusters\[1\]\.direction.*unit vector"):
        parse_vehicle(data, "x.toml")
    data = _benbam_data()
    del data["added_mass"]["heave"]
    with pytest.raises(VehicleError, match=r"added_mass\.heave.*required"):
        parse_vehicle(data, "x.toml")
    data = _benbam_data()
    data["vehicle"]["cb"] = [0.0, 0.0, -0.1]  # misspelt cb_m must not fall back to 0
    with pytest.raises(VehicleError, match=r"vehicle\.cb: .*allowed: keys .*cb_m"):
        parse_vehicle(data, "x.toml")
    data = _benbam_data()
    data["thrusters"][0]["gain"] = 40.0
    with pytest.raises(VehicleError, match=r"thrusters\[0\]\.gain: "):
        parse_vehicle(data, "x.toml")
    data = _benbam_data()
    data["vehicle"]["inertia_kg_m2"] = [5.0, 1.0, 1.0]
    with pytest.raises(VehicleError, match="triangle inequality"):
        parse_vehicle(data, "x.toml")


def test_command_errors_name_the_thruster(rov, benbam):
    with pytest.raises(ValueError, match=r"commands: got 3 value.*one per thruster \(2"):
        simulate(benbam, 1.0, commands=[0.1, 0.1, 0.1])
    with pytest.raises(ValueError, match=r"thruster 'starboard': got 1\.5.*\|u\| ≤ 1"):
        simulate(benbam, 1.0, commands=[0.1, 1.5])
    # a callable that exceeds the limit later in the run is refused at that time
    with pytest.raises(ValueError, match=r"thruster '3'"):
        simulate(rov, 5.0, commands=lambda t: [0, 0, min(2.0, t), 0, 0, 0, 0, 0])
    with pytest.raises(ValueError, match="duration_s"):
        simulate(rov, 0.0, force=np.zeros(6))
    with pytest.raises(ValueError, match="force: got"):
        simulate(rov, 1.0, force=[1, 2, 3])


def test_singular_pitch_is_a_clear_error(rov):
    with pytest.raises(SingularAttitude, match="singular"):
        simulate(rov, 1.0, eta0=[0, 0, 0, 0, math.pi / 2, 0])
    # driven through ±90°: a strong pitch torque on a damped-out vehicle
    free = rov.with_coefficients(ZERO_DAMPING)
    with pytest.raises(SingularAttitude, match=r"t = "):
        simulate(free, 20.0, force=[0, 0, 0, 0, 20.0, 0])


def test_trajectory_json_decimates_keeping_the_end(benbam):
    traj = simulate(benbam, 1.0, commands=[0.2, 0.2], dt=0.01)
    doc = traj.to_json(every=30)
    assert doc["t"][-1] == pytest.approx(1.0)
    assert len(doc["t"]) == len(doc["nu"]["u"]) == 5  # 0, .3, .6, .9, 1.0
    assert set(doc["eta"]) == {"x", "y", "z", "phi", "theta", "psi"}


def test_short_input_pulse_is_not_stepped_over(benbam):
    """A callable input is sampled at least every dt: a 50 ms, 20 N pulse gives the
    vehicle its impulse (1 N·s) / (m + m_a) of surge speed."""
    pulse = simulate(benbam, 20.0, commands=lambda t: [0.5 if 5.0 <= t < 5.05 else 0.0, 0.0])
    peak = np.max(pulse.nu[:, 0])
    assert peak == pytest.approx(20.0 * 0.05 / benbam.total_inertia("surge"), rel=0.02)
    assert pulse.tau[np.searchsorted(pulse.t, 5.02), 0] == pytest.approx(20.0)


def test_apply_result_json_uses_value_and_std(benbam):
    from estimation.vehicle.apply_estimates import apply_result_json

    doc = {
        "axis": "yaw",
        "coefficients": {
            "inertia": {"value": 9.0, "std": 0.4},
            "linear_damping": {"value": 0.2, "std": 0.05},
            "quadratic_damping": {"value": 3.9, "std": None},
        },
    }
    veh = apply_result_json(benbam, doc, "result 7")
    assert veh.total_inertia("yaw") == pytest.approx(9.0)
    assert veh.sigma["added_mass.yaw"] == 0.4 and veh.sigma["linear_damping.yaw"] == 0.05
    assert "quadratic_damping.yaw" not in veh.sigma
    doc["coefficients"]["quadratic_damping"]["value"] = -1.0
    with pytest.raises(VehicleError, match=r"result 7: quadratic_damping\.yaw: got -1\.0"):
        apply_result_json(benbam, doc, "result 7")
    with pytest.raises(VehicleError, match="result 7: axis: got 'heading'"):
        apply_result_json(benbam, {"axis": "heading"}, "result 7")


def test_a_free_decay_s_result_plugs_into_its_dof(benbam):
    """A heave decay's document (``dof``, no ``axis``) that was given the body's own inertia
    identified the added part: the vehicle's heave inertia is their sum, its σ the fit's; no
    quadratic damping found leaves the vehicle's."""
    from estimation.vehicle.apply_estimates import apply_result_json

    body = benbam.rigid_body_inertia("heave")
    doc = {
        "kind": "decay",
        "dof": "heave",
        "coefficients": {
            "inertia": {"value": 12.5, "std": 0.3},
            "linear_damping": {"value": 4.0, "std": 0.1},
        },
        "known": {"known_inertia": {"value": body, "std": 0.0}},
    }
    veh = apply_result_json(benbam, doc, "result 3")
    assert veh.total_inertia("heave") == pytest.approx(body + 12.5)
    assert veh.sigma["added_mass.heave"] == 0.3
    assert veh.coefficients()["linear_damping.heave"] == 4.0
    kept = benbam.coefficients()["quadratic_damping.heave"]
    assert veh.coefficients()["quadratic_damping.heave"] == kept
    # without the body's inertia given, the identified inertia is the whole
    whole = {**doc["coefficients"], "inertia": {"value": body + 5.0, "std": 0.3}}
    veh = apply_result_json(benbam, {**doc, "coefficients": whole, "known": {}}, "result 3")
    assert veh.total_inertia("heave") == pytest.approx(body + 5.0)


def test_evaluation_budget_refuses_a_violent_input(benbam):
    with pytest.raises(ValueError, match=r"duration_s: .*too fast"):
        simulate(benbam, 600.0, force=lambda t: [0, 0, 0, 0, 0, math.sin(t)], max_evaluations=2000)
    # the same budget is plenty for an ordinary manoeuvre
    simulate(benbam, 60.0, commands=[0.3, 0.3], max_evaluations=2000)


def test_vehicles_are_hashable_values(rov):
    """Equal descriptions are equal and hash alike (usable as cache keys)."""
    again = load_vehicle(VEHICLES / "seed002-rov.toml")
    assert again == rov and hash(again) == hash(rov)
    assert rov.with_coefficients({"linear_damping.yaw": 2.0}) != rov


def test_a_pendulum_result_plugs_in_added_mass_and_damping_of_its_swing_axis(benbam):
    from estimation.vehicle.apply_estimates import apply_result_json

    doc = {
        "analysis": "pendulum",
        "axis": "surge",
        "coefficients": {
            "added_mass": {"value": 110.0, "std": 0.5},
            "linear_damping": {"value": 21.0, "std": 0.2},
        },
    }
    veh = apply_result_json(benbam, doc, "result 9")
    assert veh.total_inertia("surge") == pytest.approx(benbam.mass_kg + 110.0)
    assert veh.coefficients()["linear_damping.surge"] == pytest.approx(21.0)
    # no quadratic term found: the vehicle's own stays
    assert veh.coefficients()["quadratic_damping.surge"] == pytest.approx(
        benbam.coefficients()["quadratic_damping.surge"]
    )
    assert veh.sigma["added_mass.surge"] == 0.5
    doc["coefficients"]["quadratic_damping"] = {"value": 230.0, "std": 3.0}
    assert apply_result_json(benbam, doc).coefficients()["quadratic_damping.surge"] == 230.0
