"""Sequences: validation up front, pause/resume between steps, abort, the seed campaign file."""

from __future__ import annotations

import asyncio
from pathlib import Path

import pytest

from daq.procedures.params import ParameterError
from daq.procedures.sequence import SequenceControl, load_sequence, parse_sequence, run_sequence
from tests.support.progress_log import ProgressLog

pytestmark = pytest.mark.simtime

ROOT = Path(__file__).resolve().parents[2]


def test_seed_campaign_file_is_valid(source):
    seq = load_sequence(ROOT / "fixtures/sequences/seed000-campaign.toml", source.rig)
    assert [s.kind for s in seq.steps] == ["tow"] * 4 + ["spin"] * 4
    assert [round(s.force_n, 1) for s in seq.steps[:4]] == [4.9, 24.5, 44.1, 83.3]
    assert [round(s.torque_nm, 3) for s in seq.steps[4:]] == [0.454, 0.907, 1.361, 2.269]
    assert seq.rest_s == 30


def test_every_step_is_checked_before_anything_runs(source):
    data = {
        "steps": [
            {"kind": "tow", "force_n": 24.5},
            {"kind": "spin", "torque_nm": 0},  # zero is no test (negative is a reverse one)
            {"kind": "jump"},
        ]
    }
    with pytest.raises(ParameterError) as err:
        parse_sequence(data, source.rig)
    fields = [p[0] for p in err.value.problems]
    assert fields == ["steps[1].torque_nm", "steps[2].kind"]


def _short(kind: str, **kw) -> dict:
    return {"kind": kind, "max_time_s": 1.0, "baseline_s": 0.2, **kw}


async def test_a_sequence_with_reverse_steps_runs_them_the_other_way(session, store):
    seq = parse_sequence(
        {"steps": [_short("tow", force_n=-24.5), _short("spin", torque_nm=-0.907)]}, session.rig
    )
    assert [s.reverse for s in seq.steps] == [True, True]
    outcome = await run_sequence(session, seq)
    outcomes = outcome.runs
    assert [o.status for o in outcomes] == ["completed", "completed"]
    tow, spin = (store.samples(o.run_id).channels for o in outcomes)
    far = session.rig.geometry.reverse_start
    assert tow["tow_position"][0] == pytest.approx(far, abs=1e-3)
    assert tow["tow_position"][-1] < far - 0.05
    assert spin["yaw_angle"][-1] < -0.05


async def test_sequence_pauses_between_steps_and_resumes(session, store):
    seq = parse_sequence(
        {
            "rest_s": 0.2,
            "repeats": 1,
            "steps": [_short("tow", force_n=24.5), _short("spin", torque_nm=0.907)],
        },
        session.rig,
    )
    control = SequenceControl()
    progress = ProgressLog()
    task = asyncio.create_task(run_sequence(session, seq, control=control, progress=progress))
    await progress.wait(lambda p: p.message.startswith("step 1/2"), "the first step", task=task)
    control.pause()  # the running step finishes; the next one waits
    await progress.wait(lambda p: p.state == "paused", "paused between the steps", task=task)
    assert control.paused and len(store.list_runs()) == 1
    assert store.list_runs()[0].status == "completed"
    assert not any(p.message.startswith("step 2/2") for p in progress.reports)
    control.resume()
    outcome = await asyncio.wait_for(task, 20)
    assert outcome.status == "completed"
    assert [r.kind for r in outcome.runs] == ["tow", "spin"]
    assert all(r.status == "completed" for r in outcome.runs)


async def test_sequence_abort_stops_the_running_step(session, store):
    seq = parse_sequence(
        {"repeats": 3, "steps": [_short("tow", force_n=24.5, max_time_s=20)]}, session.rig
    )
    control = SequenceControl()
    progress = ProgressLog()
    task = asyncio.create_task(run_sequence(session, seq, control=control, progress=progress))
    await progress.wait(lambda p: "tow:" in p.message, "the first tow moving", task=task)
    control.abort.set("operator abort (test)")
    outcome = await asyncio.wait_for(task, 10)
    assert outcome.status == "aborted" and "operator abort (test)" in outcome.reason
    assert [r.status for r in outcome.runs] == ["aborted"]
    assert await session.plc.read("tow_release") == 0
