"""The live stream over a real uvicorn socket: samples, job events, down-sampling, and a
client that stops reading never slows the clock. The rig behind it runs in process on
simulated time (paced, tests/api/conftest.py): the clock's times are exact, so the
assertions on them are the clock's, not the host's."""

from __future__ import annotations

import itertools
import json
import socket
import time

import pytest

from tests.api.conftest import AUTH, SHORT_TOW, start_job, wait_job
from tests.support.waiting import wait_until

pytestmark = pytest.mark.simtime


def _events(http, query: str) -> list[tuple[str, dict]]:
    out = []
    with http.stream("GET", f"/api/stream?{query}") as r:
        assert r.status_code == 200
        assert r.headers["content-type"].startswith("text/event-stream")
        kind = None
        for line in r.iter_lines():
            if line.startswith("event: "):
                kind = line[7:]
            elif line.startswith("data: "):
                out.append((kind, json.loads(line[6:])))
    return out


def test_stream_delivers_live_samples_at_the_clock_rate(live_url, service):
    events = _events(live_url, "max_events=8&jobs=false")
    assert [k for k, _ in events] == ["sample"] * 8
    seqs = [d["seq"] for _, d in events]
    assert seqs == sorted(seqs) and len(set(seqs)) == 8
    assert {"tow_position", "yaw_angle", "load_cell"} <= set(events[0][1]["channels"])
    # the thruster commands last sent (zero: nothing drives them), one per thruster
    assert events[0][1]["thrusters"] == [0.0] * service.source.rig.thrusters.count
    # Each sample is stamped on the 10 Hz clock's slot grid (in-process reads take no time).
    times = [d["t_mono"] - d["seq"] / 10 for _, d in events]
    assert times == pytest.approx([times[0]] * 8, abs=1e-9)


def test_stream_down_samples_for_slow_clients(live_url):
    events = _events(live_url, "max_hz=2&max_s=2.1&jobs=false")
    samples = [d for k, d in events if k == "sample"]
    assert len(samples) >= 3
    # 2 Hz of a 10 Hz clock: every fifth slot, the four between counted as thinned.
    gaps = [b["t_mono"] - a["t_mono"] for a, b in itertools.pairwise(samples)]
    assert gaps == pytest.approx([0.5] * len(gaps), abs=1e-9)
    assert all(d["thinned"] == 4 for d in samples[1:])


def test_stream_carries_job_events_of_a_tow(live_url, client):
    with live_url.stream("GET", "/api/stream?samples=false&max_s=15") as r:
        job_id = start_job(client, "/api/jobs/tow", SHORT_TOW)
        states = []
        kind = None
        for line in r.iter_lines():
            if line.startswith("event: "):
                kind = line[7:]
            elif line.startswith("data: ") and kind == "job":
                job = json.loads(line[6:])
                if job["id"] == job_id:
                    states.append(job["state"])
                    if job["state"] in ("completed", "aborted", "failed"):
                        break
    # "queued" may be published before this stream's subscription is in place; from then
    # on the job's changes must all arrive, in order, to the end.
    assert "running" in states
    assert states[-1] == "completed"
    order = {"queued": 0, "running": 1, "completed": 2}
    assert [order[s] for s in states] == sorted(order[s] for s in states)


def test_a_client_that_stops_reading_never_slows_the_clock(live_url, client, service):
    """Open streams whose reader never reads, run a tow; the clock keeps time."""
    host, port = live_url.base_url.host, live_url.base_url.port
    stalled = []
    for _ in range(3):
        s = socket.create_connection((host, port))
        s.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
        s.sendall(
            f"GET /api/stream HTTP/1.1\r\nHost: {host}\r\n"
            f"Authorization: {AUTH['Authorization']}\r\n\r\n".encode()
        )
        stalled.append(s)
    try:
        acq = service.session.acquisition
        ticks, skipped = acq.stats.ticks, acq.stats.skipped_slots
        job_id = start_job(client, "/api/jobs/tow", SHORT_TOW)
        job = wait_job(client, job_id)
        assert job["state"] == "completed"
        assert acq.stats.ticks - ticks >= 18  # the tow's 1.8 s at least, on the clock's time
        assert acq.stats.skipped_slots == skipped  # the clock kept every slot
        assert acq.stats.dropped.get("api-stream", 0) == 0  # the hand-off never backed up
        assert service.broadcaster.client_count >= 3
    finally:
        for s in stalled:
            s.close()
    wait_until(
        lambda: service.broadcaster.client_count == 0, "vanished clients dropped", timeout_s=20
    )


def test_broadcaster_bounds_a_stuck_client_and_publishing_stays_cheap():
    """A client whose loop never drains: its queue stays bounded, drops are counted."""
    import asyncio

    from api.core.stream import CLIENT_QUEUE, Broadcaster, Client
    from daq.sample import Sample

    loop = asyncio.new_event_loop()
    try:
        b = Broadcaster()
        stuck = Client(loop, max_hz=None)
        slow = Client(loop, max_hz=1.0)
        b.add(stuck)
        b.add(slow)
        t0 = time.perf_counter()
        for i in range(5000):
            b.publish_sample(Sample(i, i / 100, 1e9 + i / 100, {"tow_position": 0.1 * i}))
        per_sample = (time.perf_counter() - t0) / 5000
        assert len(stuck.queue) == CLIENT_QUEUE
        assert stuck.dropped == 5000 - CLIENT_QUEUE
        assert stuck.queue[-1][1]["seq"] == 4999  # the newest kept, the oldest dropped
        assert len(slow.queue) == 50  # 50 s of samples at max_hz=1
        assert per_sample < 0.001
    finally:
        loop.close()


def _publish_jittered(b, n: int, clock_hz: float, jitter_s: float, seed: int = 1) -> None:
    import random

    from daq.sample import Sample

    rng = random.Random(seed)
    for i in range(n):
        t = i / clock_hz + rng.uniform(-jitter_s, jitter_s)
        b.publish_sample(Sample(i, t, 1e9 + t, {"tow_position": 0.0}))


def test_down_sampling_at_the_clock_rate_keeps_every_sample_despite_jitter():
    """10 Hz asked of a 10 Hz clock whose ticks jitter by ±20 ms: all 200 samples arrive."""
    import asyncio

    from api.core.stream import Broadcaster, Client

    loop = asyncio.new_event_loop()
    try:
        b = Broadcaster()
        same = Client(loop, max_hz=10.0)
        b.add(same)
        _publish_jittered(b, 200, 10.0, 0.02)
        assert len(same.queue) == 200
        assert all(d["thinned"] == 0 for _, d in same.queue)
    finally:
        loop.close()


def test_down_sampling_keeps_the_requested_rate_and_counts_what_it_thins():
    import asyncio

    from api.core.stream import Broadcaster, Client

    loop = asyncio.new_event_loop()
    try:
        b = Broadcaster()
        slow = Client(loop, max_hz=2.0)
        third = Client(loop, max_hz=10.0 / 3)  # not a divisor of the clock rate
        b.add(slow)
        b.add(third)
        _publish_jittered(b, 200, 10.0, 0.02)  # 20 s
        got = [d for _, d in slow.queue]
        assert len(got) == 40  # 2 Hz for 20 s
        assert min(b["t_mono"] - a["t_mono"] for a, b in itertools.pairwise(got)) > 0.4
        # every clock sample is either sent or counted as thinned before the next one sent
        assert len(got) + sum(d["thinned"] for d in got) + slow.thinned == 200
        span = got[-1]["t_mono"] - got[0]["t_mono"]
        assert (len(got) - 1) / span <= 2.0 + 1e-9
        sent = [d for _, d in third.queue]
        assert len(sent) in (66, 67)  # 10/3 Hz for 20 s, never above
        assert len(sent) + sum(d["thinned"] for d in sent) + third.thinned == 200
    finally:
        loop.close()


def test_stream_at_the_clock_rate_thins_nothing(live_url):
    events = _events(live_url, "max_hz=10&max_events=20&jobs=false")
    samples = [d for k, d in events if k == "sample"]
    assert len(samples) == 20
    assert [d["thinned"] for d in samples] == [0] * 20
