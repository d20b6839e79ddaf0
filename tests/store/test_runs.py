"""Run lifecycle, lookup by id prefix, listing filters and argument errors."""

from __future__ import annotations

import time
from datetime import UTC, datetime, timedelta

import pytest

from daq.store import AmbiguousRunId, RunNotFound, Store
from tests.store.helpers import RIG_TOML, make_samples, new_run


def test_a_run_records_its_configuration_and_how_it_ended(store: Store) -> None:
    before = datetime.now(UTC)
    run_id = new_run(store, scenario_toml='[scenario]\nname = "calm"\n')
    run = store.get_run(run_id)
    assert run.id == run_id and len(run_id) == 36
    assert (run.kind, run.status, run.reason) == ("tow", "running", None)
    assert run.parameters == {"force_n": 24.5}
    assert run.channel_names == ("tow_position", "load_cell")
    assert (run.rig_name, run.vehicle) == ("BENBAM", "BENBAM-1")
    assert run.rig_toml == RIG_TOML and run.scenario_toml.startswith("[scenario]")
    assert run.software_version == "0.1.0"
    assert run.started_at.tzinfo is not None
    assert before - timedelta(seconds=1) <= run.started_at <= datetime.now(UTC)
    assert run.stopped_at is None and run.duration_s is None

    store.add_samples(run_id, make_samples(0, 25))
    store.finish_run(run_id, "aborted", "device lost")
    run = store.get_run(run_id)
    assert (run.status, run.reason, run.sample_count) == ("aborted", "device lost", 25)
    assert run.stopped_at >= run.started_at
    document = run.to_json()
    assert document["status"] == "aborted" and document["started_at"].endswith("+00:00")
    assert document["rig_toml"] == RIG_TOML


def test_finishing_checks_the_status_reason_and_that_the_run_is_still_running(
    store: Store,
) -> None:
    run_id = new_run(store)
    with pytest.raises(ValueError, match="status: 'done' is not allowed; use one of completed"):
        store.finish_run(run_id, "done")
    with pytest.raises(ValueError, match="aborted run needs a reason"):
        store.finish_run(run_id, "aborted")
    store.finish_run(run_id, "completed")
    with pytest.raises(ValueError, match="already ended as 'completed'"):
        store.finish_run(run_id, "aborted", "operator")
    assert store.get_run(run_id).status == "completed"


def test_bad_run_arguments_name_the_field_and_write_nothing(store: Store) -> None:
    cases = [
        ({"kind": "Tow!"}, "kind: 'Tow!' is not allowed"),
        ({"parameters": {"force_n": float("nan")}}, "parameters: .* not storable as JSON"),
        ({"parameters": [1]}, "parameters: expected a dict"),
        ({"channel_names": []}, r"channel_names: \[\] is not allowed"),
        ({"channel_names": ["a", "a"]}, "channel_names: a repeated"),
        ({"channel_names": ["a,b"]}, "channel_names: 'a,b' is not allowed"),
        ({"rig_name": " "}, "rig_name: ' ' is not allowed"),
    ]
    for override, message in cases:
        with pytest.raises(ValueError, match=message):
            new_run(store, **override)
    assert store.list_runs() == []


def test_lookup_by_unique_prefix_and_clear_errors(store: Store) -> None:
    ids = [new_run(store) for _ in range(17)]  # 17 uuids: two must share a first hex digit
    for run_id in ids:
        assert store.get_run(run_id[:8].upper()).id == run_id
    firsts = [r[0] for r in ids]
    shared = next(c for c in firsts if firsts.count(c) > 1)
    with pytest.raises(AmbiguousRunId, match=f"prefix '{shared}' matches several runs"):
        store.get_run(shared)
    with pytest.raises(RunNotFound, match="no run with id 'ffffffff-ffff'"):
        store.get_run("ffffffff-ffff")
    # An id no run can have is an unknown id (404 on the API), saying what an id looks like.
    with pytest.raises(RunNotFound, match="no run with id 'tow%': a run id is a uuid"):
        store.get_run("tow%")
    with pytest.raises(RunNotFound, match=r"'a{40}…'"):  # long ids are cut in the message
        store.get_run("a" * 100)
    with pytest.raises(RunNotFound) as unknown:
        store.get_run("ffff0000")
    assert "sqlite" not in str(unknown.value) and "Store(" not in str(unknown.value)
    with pytest.raises(KeyError):  # RunNotFound is a KeyError too
        store.samples("0000000000")


def test_list_runs_filters_and_pages(store: Store) -> None:
    tow_a = new_run(store, vehicle="alpha")
    time.sleep(0.02)  # distinct creation times: the order tested is by start time
    spin_a = new_run(store, kind="spin", vehicle="alpha", parameters={"torque_nm": 0.907})
    time.sleep(0.02)  # distinct creation times
    tow_b = new_run(store, vehicle="bravo")
    store.finish_run(tow_a, "completed")
    store.finish_run(spin_a, "aborted", "operator")

    assert [r.id for r in store.list_runs()] == [tow_b, spin_a, tow_a]  # newest first
    assert [r.id for r in store.list_runs(kind="tow")] == [tow_b, tow_a]
    assert [r.id for r in store.list_runs(status="aborted")] == [spin_a]
    assert [r.id for r in store.list_runs(vehicle="alpha")] == [spin_a, tow_a]
    assert [r.id for r in store.list_runs(kind="tow", status="running")] == [tow_b]
    for run in store.list_runs():  # a run's own start time is inside since=, outside until=
        assert run.id in [r.id for r in store.list_runs(since=run.started_at)]
        assert run.id not in [r.id for r in store.list_runs(until=run.started_at)]
    middle = store.get_run(spin_a).started_at
    assert [r.id for r in store.list_runs(since=middle)] == [tow_b, spin_a]
    assert [r.id for r in store.list_runs(until=middle)] == [tow_a]
    naive_utc = middle.astimezone(UTC).replace(tzinfo=None)
    assert [r.id for r in store.list_runs(since=naive_utc)] == [tow_b, spin_a]
    assert [r.id for r in store.list_runs(limit=1, offset=1)] == [spin_a]
    assert store.list_runs(vehicle="charlie") == []
    with pytest.raises(ValueError, match="status: 'lost' is not allowed"):
        store.list_runs(status="lost")
    with pytest.raises(ValueError, match="limit: 0 is not allowed"):
        store.list_runs(limit=0)


def test_events_and_results_link_to_runs(store: Store) -> None:
    first, second = new_run(store), new_run(store)
    store.add_event(None, "info", "rig service started")
    store.add_event(first, "operator", "weight hung", {"hung_mass_kg": 2.5})
    store.add_event(second, "limit", "end of travel")
    assert [e.message for e in store.events()] == [
        "rig service started",
        "weight hung",
        "end of travel",
    ]
    (event,) = store.events(first)
    assert (event.run_id, event.kind, event.data) == (first, "operator", {"hung_mass_kg": 2.5})
    assert event.to_json()["time"].endswith("+00:00")

    joint = store.add_result([first, second], "estimation", {"linear_damping": 1.5})
    calibration = store.add_result([second[:10]], "calibration", {"k_n_per_unit": 0.1})
    assert {r.id for r in store.results(first)} == {joint}
    assert {r.id for r in store.results(second)} == {joint, calibration}
    assert [r.id for r in store.results(kind="calibration")] == [calibration]
    result = store.results(first)[0]
    assert set(result.run_ids) == {first, second}
    assert result.data == {"linear_damping": 1.5}
    with pytest.raises(
        ValueError, match=r"run_ids: \[\] is not allowed; give a list of ≥ 1 run ids"
    ):
        store.add_result([], "estimation", {})
    with pytest.raises(RunNotFound):
        store.add_result(["abcdef12"], "estimation", {})
    with pytest.raises(ValueError, match="kind: 'Fault' is not allowed"):
        store.add_event(first, "Fault", "x")
    assert len(store.results()) == 2 and len(store.events()) == 3
