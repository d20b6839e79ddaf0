"""Job updates on the live stream are thinned to what changed: the whole job document when
more than its progress changed, else a small ``job_progress`` event, at most ``max_hz`` per
job, and the last progress always arrives (in process, on the client's own event loop, on
simulated time: the pacing and the thinning share one clock, so the count is exact under load)."""

from __future__ import annotations

import asyncio
import json

import pytest

from api.core.stream import Broadcaster, Client

pytestmark = pytest.mark.simtime


def _job(state: str, message: str, **extra) -> dict:
    return {
        "id": "j1",
        "kind": "tow",
        "state": state,
        "label": "tow 24.5 N",
        "parameters": {"force_n": 24.5, "notes": "x" * 1500},  # a document of ~1.8 KB
        "run_ids": ["r1"],
        "progress": {"message": message, "fraction": 0.0},
    } | extra


async def _collect(client: Client, seconds: float) -> list[tuple[str, dict]]:
    await asyncio.sleep(seconds)  # an observation window on the client's loop
    events = list(client.queue)
    client.queue.clear()
    return events


async def test_progress_only_updates_are_small_and_thinned_to_max_hz():
    broadcaster = Broadcaster()
    client = Client(asyncio.get_running_loop(), max_hz=2.0, samples=False)
    broadcaster.add(client)
    broadcaster.publish_job(_job("running", "tow: 0.00 m in 0.0 s"))
    for k in range(1, 10):  # 9 progress updates in 0.9 s, as a 10 Hz tow sends them
        broadcaster.publish_job(_job("running", f"tow: 0.{k:02d} m in 0.{k} s"))
        await asyncio.sleep(0.1)
    events = await _collect(client, 0.6)
    kinds = [k for k, _ in events]
    assert kinds[0] == "job" and set(kinds[1:]) == {"job_progress"}
    # At 2 Hz, 9 updates over 0.9 s become 3 progress events (at 0, 0.5 and 1.0 s), and the
    # last one arrives.
    assert kinds.count("job_progress") == 3, kinds
    assert events[-1][1]["progress"]["message"] == "tow: 0.09 m in 0.9 s"
    full, small = len(json.dumps(events[0][1])), len(json.dumps(events[1][1]))
    assert full > 1500 and small < 150, (full, small)
    # A change beyond progress (the state) is a whole document again, at once.
    broadcaster.publish_job(_job("completed", "done", outcome={"status": "completed"}))
    (ended,) = await _collect(client, 0.05)
    assert ended[0] == "job" and ended[1]["state"] == "completed"


async def test_without_max_hz_every_progress_change_is_sent_and_repeats_are_not():
    broadcaster = Broadcaster()
    client = Client(asyncio.get_running_loop(), max_hz=None, samples=False)
    broadcaster.add(client)
    for message in ("a", "b", "b", "c"):
        broadcaster.publish_job(_job("running", message))
    events = await _collect(client, 0.05)
    assert [k for k, _ in events] == ["job", "job_progress", "job_progress"]
    assert [d["progress"]["message"] for _, d in events] == ["a", "b", "c"]
