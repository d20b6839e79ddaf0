"""Tows and spins recorded on a live rig session, each run to completion (the chains'
recordings: tests/integration, the procedure tests)."""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any

from daq.procedures.motion import run_motion_test
from daq.procedures.requests import SpinRequest, TowRequest, spin_parameters, tow_parameters
from daq.session import RigSession


async def completed_runs(
    session: RigSession, kind: str, drives: Iterable[float], **raw: Any
) -> list[str]:
    """One ``kind`` run ("tow": ``force_n`` in N, "spin": ``torque_nm`` in N·m) per drive,
    with the request's other fields ``raw``; each must complete. Their run ids in order."""
    ids = []
    for drive in drives:
        params: TowRequest | SpinRequest
        if kind == "tow":
            params = tow_parameters(raw | {"force_n": drive}, session.rig)
        else:
            params = spin_parameters(raw | {"torque_nm": drive}, session.rig)
        outcome = await run_motion_test(session, params)
        assert outcome.status == "completed", outcome
        ids.append(outcome.run_id)
    return ids
