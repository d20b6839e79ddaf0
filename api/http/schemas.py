"""Request and response models of the HTTP API (they make the OpenAPI document).

Request bodies are strict (``"24.5"`` is not a number, unknown fields are refused); a
procedure's body is its run kind's request model (``daq.procedures.requests``), whose
validators check the rig's limits: the API and the CLI name the field and range alike."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, Literal

from pydantic import BaseModel, Field

from daq.procedures.requests import StrictRequest
from daq.store.schema import JobState
from daq.vocabulary import RunKind

#: What a job runs: one run kind, a sequence of them, or an analysis.
JOB_KINDS = (
    *(k.value for k in RunKind),
    *("sequence", "estimation", "crosscheck", "campaign", "queue_stop"),
)
if TYPE_CHECKING:
    JobKind = str  # a name of JOB_KINDS: what the type checker can know of a computed Literal
else:
    JobKind = Literal[JOB_KINDS]  # what pydantic checks and the OpenAPI schema lists


# ---- errors ---------------------------------------------------------------------------
class FieldProblem(BaseModel):
    field: str = Field(description="The parameter, e.g. 'force_n' or 'steps[2].torque_nm'.")
    value: Any = Field(None, description="The value given (null when missing).")
    allowed: str = Field(description="What is allowed, e.g. 'allowed 0 < force_n ≤ 100 N'.")
    message: str


class ErrorBody(BaseModel):
    """Every error: a clear message; ``errors`` for bad input, ``holder`` for a busy rig."""

    detail: str
    errors: list[FieldProblem] | None = None
    holder: str | None = None


def error_responses(*codes: int) -> dict[int | str, dict[str, Any]]:
    """OpenAPI declarations of the error responses a route can give."""
    text = {
        401: "Missing or wrong bearer token",
        403: "The token's user has role viewer; this needs role operator",
        404: "Unknown id",
        409: "Conflict: the rig is busy (holder named) or the job is in the wrong state",
        413: "Upload too large",
        422: "Bad input: each problem names the field, the value and what is allowed",
        423: "The rig is held by another user (holder and reason named)",
        503: "The rig service is not running",
    }
    return {code: {"model": ErrorBody, "description": text[code]} for code in codes}


def file_response(
    content: dict[str, dict[str, Any]], description: str
) -> dict[int | str, dict[str, Any]]:
    """OpenAPI declaration of a 200 answer that is not JSON: its media types (``content``)
    and what it is; ``| error_responses(...)`` adds the errors."""
    return {200: {"content": content, "description": description}}


def csv_upload_body(description: str) -> dict[str, Any]:
    """OpenAPI declaration (``openapi_extra``) of a route whose body is a raw CSV upload,
    read from the request stream rather than parsed by FastAPI."""
    content = {"text/csv": {"schema": {"type": "string"}}}
    return {"requestBody": {"required": True, "content": content, "description": description}}


# ---- jobs --------------------------------------------------------------------------------
class JobProgress(BaseModel):
    fraction: float = Field(description="0..1")
    message: str


class OperatorActOut(BaseModel):
    name: str
    instruction: str
    value: float | None = None
    reverse: bool = Field(
        False,
        description="A reverse test's rigging: the tow line over the far-end pulley, or the "
        "spin cord wound the other way round the drum.",
    )


class JobOut(BaseModel):
    id: str
    kind: JobKind
    label: str
    state: JobState
    progress: JobProgress
    parameters: dict[str, Any]
    parameters_labelled: list[ParameterOut] = Field(
        [], description="The parameters labelled with units; a sequence's steps one each."
    )
    request: dict[str, Any] | None = Field(
        None,
        description="The request body a procedure job was submitted with (what a re-queue "
        "submits again); null for analyses.",
    )
    run_ids: list[str]
    outcome: dict[str, Any] | None = Field(
        None, description="Run outcome(s); for an estimation the result JSON of issue 4."
    )
    error: str | None = None
    result_id: int | None = None
    operator_act: OperatorActOut | None = Field(
        None, description="What the operator must do (state waiting_for_operator)."
    )
    position: int | None = Field(
        None, description="Place in the rig's queue (1 = next to run) while ``queued``."
    )
    created_at: str = Field(description="ISO 8601, UTC (like a run's times)")
    started_at: str | None = Field(None, description="ISO 8601, UTC")
    finished_at: str | None = Field(None, description="ISO 8601, UTC")
    user: str | None = Field(
        None, description="The named user who asked for the job (`default`: the service token)."
    )
    notes: list[str] = Field(
        default_factory=list,
        description="What the request became, e.g. a force rounded to a whole-gram weight "
        "(the run's parameters keep both: `requested` and the applied value).",
    )


class JobEventOut(BaseModel):
    t_wall: str = Field(description="ISO 8601, UTC")
    state: JobState
    fraction: float
    message: str


class QueueOut(BaseModel):
    paused: bool = Field(description="True: no queued job starts until the queue is resumed.")
    reason: str | None = Field(None, description="Why the queue is paused.")
    running: JobOut | None = Field(None, description="The job holding the rig, if any.")
    jobs: list[JobOut] = Field(description="Queued jobs in the order they will run.")


class SequenceStepOut(BaseModel):
    kind: str
    parameters_labelled: list[ParameterOut]


class SequenceFileOut(BaseModel):
    file: str = Field(description="The file's name without .toml.")
    name: str
    rest_s: float | None = None
    repeats: int | None = None
    runs: int = Field(description="Runs the sequence records (steps × repeats).")
    steps: list[SequenceStepOut]
    content: dict[str, Any] | None = Field(
        None, description="The file as JSON: the body ``POST /api/jobs/sequence`` takes."
    )
    problems: list[str] = Field(
        description="What this rig refuses in the file, one line each (empty: it can start)."
    )


class QueueMoveRequest(StrictRequest):
    position: int = Field(description="New place in the queue, 1 = next to run.")


class EmergencyStopOut(BaseModel):
    aborted_jobs: list[str]
    safe_state: bool


# ---- rig ------------------------------------------------------------------------------------
class SampleOut(BaseModel):
    seq: int
    t_wall: float
    quality: int
    quality_flags: list[str]
    stale_channels: list[str]
    channels: dict[str, float | None]


class ClockOut(BaseModel):
    rate_hz: float
    ticks: int
    overruns: int
    late_wakeups: int = Field(
        description="Of the overruns, the wake-ups over half a period late (a busy host)."
    )
    host_stalls: int = Field(
        description="Of the other overruns, the ticks the OS kept waiting for a CPU so long "
        "that without the wait they would have ended in time (daq.cpu_wait); the rest are "
        "the device's or this process's."
    )
    skipped_slots: int
    failed_polls: int
    dropped: dict[str, int]
    lateness_p50_s: float | None
    lateness_p99_s: float | None
    lateness_max_s: float | None
    lateness_window: int


class ThrustersOut(BaseModel):
    state: str
    output: list[float]
    sent: int
    acked: int
    timeouts: int
    naks: dict[str, int]
    stale_zeroings: int


class CapabilityOut(BaseModel):
    available: bool
    reason: str | None = Field(None, description="What the rig file lacks (absent if available).")
    drives: dict[str, CapabilityOut] | None = None


class RigStatus(BaseModel):
    running: bool
    error: str | None = None
    simulated: bool
    rig_name: str
    vehicle: str | None = None
    realtime: bool = Field(False, description="The rig thread runs SCHED_FIFO.")
    connected: bool = False
    device_lost: bool = False
    lock_holder: str | None = None
    armed: bool = False
    current_job: JobOut | None = None
    sample: SampleOut | None = None
    stale_channels: list[str] = []
    units: dict[str, str] = Field(
        {},
        description="Unit of each channel, from the rig file, and of the thrusters' telemetry "
        "channels (thruster1_rpm: rpm, thruster1_current: A) samples carry while a run logs "
        "them.",
    )
    clock: ClockOut | None = None
    thrusters: ThrustersOut | None = None
    limits: dict[str, float] = {}
    field_limits: dict[str, dict[str, dict[str, float]]] = Field(
        {}, description="Per kind: the rig's limit on each field it bounds, {field: {max, min?}}."
    )
    capabilities: dict[str, CapabilityOut] = Field(
        {},
        description="Per run kind: can this rig run it (tow/spin per drive), and why not.",
    )
    safety: dict[str, CapabilityOut] = Field(
        {},
        description="end_of_travel, estop, heartbeat, supply_voltage: used when the rig file "
        "lists them; the reason says what the rig does without one.",
    )
    stream_clients: int = 0
    guard: dict[str, Any] = Field(
        {},
        description="`estop`: an emergency stop not yet acknowledged (motion refused), "
        "`hold`: who holds the rig and why; each `{by, at, message}` or null.",
    )


class Health(BaseModel):
    ok: bool
    version: str
    read_requires_token: bool


# ---- runs ------------------------------------------------------------------------------------
class ParameterOut(BaseModel):
    key: str
    label: str = Field(description="What it is, in words (``max distance``).")
    value: Any
    unit: str = Field(description="SI unit; empty for a count, a word or a flag.")
    shown: str = Field(description="The value as people read it, with its unit (``4.2 m``).")


class RunOut(BaseModel):
    id: str
    kind: str
    status: str
    reason: str | None
    parameters: dict[str, Any]
    parameters_labelled: list[ParameterOut] = Field(
        [], description="The parameters that were set, labelled with units, in stored order."
    )
    started_at: str
    stopped_at: str | None
    duration_s: float | None
    sample_count: int
    rig_name: str
    vehicle: str
    channel_names: list[str]
    software_version: str
    rig_toml: str | None = None
    scenario_toml: str | None = None
    drive: Literal["weight", "thrusters"] | None = Field(
        None, description="What moved the vehicle (null: nothing, e.g. a pendulum)."
    )
    source: Literal["recorded", "imported"] = "recorded"
    source_file: str | None = Field(None, description="The imported file's name.")
    imported_at: str | None = Field(
        None, description="When it was imported (started_at stays when it was recorded)."
    )
    metadata: dict[str, Any] = Field(
        {}, description="Operator, water_temperature_c, notes, tags and free keys."
    )


class SamplesOut(BaseModel):
    run_id: str
    start_seq: int
    count: int
    next_start_seq: int | None = Field(description="Ask again from here; null at the end.")
    seq: list[int]
    t: list[float] = Field(description="s since the run's first sample")
    t_mono: list[float]
    t_wall: list[float]
    quality: list[int]
    channels: dict[str, list[float | None]]
    units: dict[str, str] = Field(
        {}, description="Each channel's unit (UDUNITS text; '1' dimensionless, '' unknown)."
    )


class EventOut(BaseModel):
    id: int
    run_id: str | None
    time: str
    kind: str
    message: str
    data: dict[str, Any] | None


class ResultOut(BaseModel):
    id: int
    kind: str
    created_at: str
    run_ids: list[str]
    software_version: str
    data: dict[str, Any]
    subject: str = Field(
        "—", description="What it is of: the record and method (surge tow test / output-error)."
    )
    report_plots: list[str] = Field([], description="Names for GET .../report/{name}.png")


class ImportOut(BaseModel):
    run_id: str
    samples: int
    from_header: dict[str, Any] = Field(
        default_factory=dict,
        description="What a towrig export's own header supplied (kind, force_n or torque_nm, "
        "hung_mass_kg, drive_column, release_time_s, vehicle).",
    )
