"""Runs you can find: metadata checked and stored with its tags, updated after, filters by
drive, source, tag and text with a total, and the local-day window."""

from __future__ import annotations

import re
from datetime import UTC, date, datetime, timedelta, timezone
from zoneinfo import ZoneInfo

import pytest

from daq.store import RunNotFound, Store
from daq.store.day_window import parse_moment, parse_tz, start_window
from daq.store.run_metadata import parse_meta_pair
from tests.store.helpers import new_run


def test_metadata_is_stored_updated_and_found_by_tag_and_text(store: Store) -> None:
    tagged = new_run(
        store,
        parameters={"force_n": 10.0, "drive": "thrusters"},
        metadata={"operator": " Ada ", "water_temperature_c": 18, "tags": ["a", "b", "a"],
                  "ballast": "Q3", "depth_m": 1.5, "dry": False},
    )  # fmt: skip
    plain = new_run(store, kind="pendulum", parameters={"start_angle_rad": 0.2})
    weighted = new_run(store, parameters={"force_n": 9.8, "hung_mass_kg": 1.0, "drive": "weight"})
    run = store.get_run(tagged)
    assert run.metadata == {"operator": "Ada", "water_temperature_c": 18.0, "tags": ["a", "b"],
                            "ballast": "Q3", "depth_m": 1.5, "dry": False}  # fmt: skip
    assert run.to_json()["metadata"] == run.metadata
    assert (run.drive, store.get_run(plain).drive, store.get_run(weighted).drive) == (
        "thrusters", None, "weight",
    )  # fmt: skip

    def ids(**filters) -> set[str]:
        found = {r.id for r in store.list_runs(**filters)}
        assert store.count_runs(**filters) == len(found)
        return found

    assert ids(tag="a") == {tagged} and ids(tag="c") == set()
    # "Q3", not hex: a search also matches the start of a run's id
    assert ids(search="ADA") == {tagged} and ids(search="q3") == {tagged}
    assert ids(search="benbam-1") == {tagged, plain, weighted}  # the vehicle
    assert ids(search=plain[:8]) == {plain}
    assert ids(search="100%") == set()  # % is a character, not a wildcard
    assert ids(drive="thrusters") == {tagged} and ids(drive="none") == {plain}
    assert ids(source="recorded") == {tagged, plain, weighted} and ids(source="imported") == set()

    after = store.set_run_metadata(
        tagged[:8], {"notes": "new fins", "ballast": None, "tags": ["c"]}
    )
    assert after.metadata == {"operator": "Ada", "water_temperature_c": 18.0, "tags": ["c"],
                              "depth_m": 1.5, "dry": False, "notes": "new fins"}  # fmt: skip
    assert ids(tag="a") == set() and ids(tag="c") == {tagged}
    store.set_run_metadata(tagged, {"tags": None})
    assert ids(tag="c") == set() and "tags" not in store.get_run(tagged).metadata
    with pytest.raises(RunNotFound):
        store.set_run_metadata("0000dead", {"notes": "x"})


@pytest.mark.parametrize(
    ("metadata", "message"),
    [
        ({"water_temperature_c": 60}, "metadata.water_temperature_c: 60 is not allowed; use -2"),
        ({"water_temperature_c": "warm"}, "metadata.water_temperature_c: 'warm'"),
        ({"operator": ""}, "metadata.operator: '' is not allowed"),
        ({"tags": "a"}, "metadata.tags: 'a' is not allowed; use a list"),
        ({"tags": ["ok", "not ok"]}, "metadata.tags[1]: 'not ok'"),
        ({"Ballast": 1}, "metadata.Ballast: this key is not allowed"),
        ({"depth": float("nan")}, "metadata.depth: nan is not allowed"),
        ({"depth": {"m": 1}}, "metadata.depth: {'m': 1} is not allowed"),
    ],
)
def test_bad_metadata_is_refused_naming_the_field_and_nothing_is_stored(
    store: Store, metadata: dict, message: str
) -> None:
    with pytest.raises(ValueError, match="^" + message.replace("[", r"\[").replace("(", r"\(")):
        new_run(store, metadata=metadata)
    assert store.list_runs() == []
    run_id = new_run(store)
    with pytest.raises(ValueError, match=r"^metadata\."):
        store.set_run_metadata(run_id, metadata)
    assert store.get_run(run_id).metadata == {}


def test_a_kind_with_one_drive_is_stored_with_it(store: Store) -> None:
    """A thrust calibration names no drive in its parameters; its kind's one drive
    (``daq.vocabulary.FIXED_DRIVE``) is its stored drive, so the drive filter finds it."""
    calibration = new_run(store, kind="thrust_calibration", parameters={"commands": [0.1, 0.2]})
    hung = new_run(store, parameters={"force_n": 9.8, "hung_mass_kg": 1.0})
    assert (store.get_run(calibration).drive, store.get_run(hung).drive) == ("thrusters", "weight")
    assert {r.id for r in store.list_runs(drive="thrusters")} == {calibration}


def test_total_and_paging_agree(store: Store) -> None:
    made = [new_run(store) for _ in range(5)]
    pages = [store.list_runs(limit=2, offset=o) for o in (0, 2, 4)]
    assert [len(p) for p in pages] == [2, 2, 1]
    assert [r.id for p in pages for r in p] == made[::-1]
    assert store.count_runs() == 5 and store.count_runs(kind="spin") == 0


def test_days_are_local_and_until_includes_its_whole_day() -> None:
    oslo = ZoneInfo("Europe/Oslo")
    low, high = start_window(date(2026, 11, 23), date(2026, 11, 23), oslo)
    assert low == datetime(2026, 11, 22, 23, 0, tzinfo=UTC)
    assert high == datetime(2026, 11, 23, 23, 0, tzinfo=UTC)  # exclusive: the next midnight
    low, high = start_window(date(2026, 3, 29), date(2026, 3, 29), oslo)  # a 23 h day
    assert high.timestamp() - low.timestamp() == 23 * 3600
    moment = datetime(2026, 11, 23, 12, 0)
    low, high = start_window(moment, moment, timezone(timedelta(hours=-5)))
    assert low == datetime(2026, 11, 23, 17, 0, tzinfo=UTC) and high > low
    assert parse_moment("since", "today", today=date(2026, 1, 2)) == date(2026, 1, 2)
    assert parse_moment("since", "yesterday", today=date(2026, 1, 1)) == date(2025, 12, 31)
    assert parse_moment("until", "2026-11-23T10:00Z") == datetime(2026, 11, 23, 10, tzinfo=UTC)
    assert parse_tz("tz", "+05:30").utcoffset(None) == timedelta(hours=5, minutes=30)
    assert parse_tz("tz", "UTC") is UTC and parse_tz("tz", None) is None
    for bad, call in (("23/11/2026", parse_moment), ("Mars/Base", parse_tz), ("+15:00", parse_tz)):
        with pytest.raises(ValueError, match=f"^x: '{re.escape(bad)}' is not allowed"):
            call("x", bad)


def test_meta_pairs_keep_numbers_as_numbers() -> None:
    assert parse_meta_pair("depth_m=1.5") == ("depth_m", 1.5)
    assert parse_meta_pair("run=3") == ("run", 3)
    assert parse_meta_pair("ballast=B3") == ("ballast", "B3")
    assert parse_meta_pair("note=a=b") == ("note", "a=b")
    with pytest.raises(ValueError, match="KEY=VALUE"):
        parse_meta_pair("novalue")


def test_a_runs_origin_keys_do_not_count_against_the_free_keys() -> None:
    """A request may carry the most free keys allowed; the job and sequence then add who,
    which job and which step without pushing the run over the limit."""
    from daq.store.run_metadata import MAX_EXTRA_KEYS, ORIGIN_KEYS, check_run_metadata

    full = {f"key_{i}": i for i in range(MAX_EXTRA_KEYS)}
    origin = dict.fromkeys(ORIGIN_KEYS, "x")
    assert check_run_metadata(full | origin) == full | origin
    with pytest.raises(ValueError, match="more than 30 free keys"):
        check_run_metadata(full | origin | {"one_more": 1})
