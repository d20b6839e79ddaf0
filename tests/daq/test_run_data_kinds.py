"""What the loader does per kind comes from the kind's axis words (``daq.vocabulary.AXES``),
not from branches on its name: the drive train's inertia (a tow's pulley as J/r², a spin's
drum as J with its radius, nothing when the thrusters drive a tow with its line unhooked),
and the end switch a tow stops on; a new axis given those words loads with no edit of
``daq/run_data.py``."""

from __future__ import annotations

import pytest

from daq import vocabulary
from daq.config import DEFAULT_RIG_FILE, load_rig
from daq.run_data import load_run_data
from daq.sample import Quality, Sample
from daq.store import Store
from daq.vocabulary import AXES, Axis, AxisTerms, DriveTrain

RIG = load_rig()
#: Sample period, s; the release (its coil set) at sample 10, the end switch at sample 40.
DT, RELEASE, SWITCH = 0.1, 10, 40


def _stored(store: Store, kind: str, parameters: dict, switch: str | None = None) -> str:
    """A run of ``kind``: its axis accelerates from the release, its release coil set then;
    with ``switch``, that channel rises at sample ``SWITCH`` (the axis still moving)."""
    terms = AXES[kind]
    names = [terms.position_channel, terms.release_coil] + ([switch] if switch else [])
    run_id = store.create_run(
        kind=kind,
        parameters=parameters,
        channel_names=names,
        rig_name=RIG.rig.name,
        vehicle="BENBAM-1",
        rig_toml=DEFAULT_RIG_FILE.read_text(),
    )
    samples = []
    for k in range(60):
        free = max(0.0, (k - RELEASE) * DT)
        channels = {terms.position_channel: 0.05 * free**2, terms.release_coil: float(k >= RELEASE)}
        if switch:
            channels[switch] = float(k >= SWITCH)
        samples.append(Sample(k, 100.0 + k * DT, 1.7e9 + k * DT, channels, Quality.OK))
    store.add_samples(run_id, samples)
    return run_id


def test_a_tows_pulley_adds_j_over_r_squared_and_its_end_switch_ends_the_window(store):
    geo = RIG.geometry
    run = load_run_data(store, _stored(store, "tow", {"force_n": 9.8}, switch="end_of_travel"))
    assert run.drive_inertia == pytest.approx(geo.pulley_inertia_kg_m2 / geo.pulley_radius_m**2)
    assert run.drum_radius_m is None
    assert run.window_found is not None
    assert run.window_found.end_source == "end_of_travel switch"
    assert run.t_end == pytest.approx(100.0 + (SWITCH - 1) * DT)


def test_a_spins_drum_adds_its_inertia_at_its_radius_and_no_end_switch_is_read(store):
    geo = RIG.geometry
    # an end_of_travel channel in a spin's samples is not a spin's end switch
    run = load_run_data(store, _stored(store, "spin", {"torque_nm": 0.5}, switch="end_of_travel"))
    assert run.drive_inertia == pytest.approx(geo.spin_drum_inertia_kg_m2)
    assert run.drum_radius_m == geo.spin_drum_radius_m
    assert run.window_found is not None
    assert run.window_found.end_source != "end_of_travel switch"


def test_a_new_axis_loads_from_its_words_with_no_edit_of_the_loader(store, monkeypatch):
    """A ``lift`` kind on a hoist: a linear axis with its own drum seen as J/r² and its own
    end switch; the loader reads both from its words."""
    lift = AxisTerms(
        Axis.SURGE, "lift_position", "m", "lift_release", "hang_lift_weight", "force_n", "N",
        end_switch="lift_top",
        drive_train=DriveTrain("spin_drum_inertia_kg_m2", "spin_drum_radius_m", True, True),
    )  # fmt: skip
    monkeypatch.setitem(AXES, "lift", lift)
    monkeypatch.setitem(vocabulary.POSITION_CHANNEL, "lift", "lift_position")
    run = load_run_data(store, _stored(store, "lift", {"force_n": 9.8}, switch="lift_top"))
    geo = RIG.geometry
    radius = geo.spin_drum_radius_m
    assert radius is not None
    assert run.drive_inertia == pytest.approx(geo.spin_drum_inertia_kg_m2 / radius**2)
    assert run.window_found is not None and run.window_found.end_source == "end_of_travel switch"
    assert run.t_end == pytest.approx(100.0 + (SWITCH - 1) * DT)
