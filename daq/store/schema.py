"""The run database's tables (SQLAlchemy Core), the one description both the code and the
Alembic revisions follow.

Times are stored as Unix seconds (float64) so SQLite and PostgreSQL behave the same;
the Python API hands out aware UTC datetimes. Samples are stored in blocks, a row per
batch holding each column as an array (``sample_blocks``): ingest is one row per flush,
reading a long run concatenates a few arrays, and the table does not depend on the rig.
"""

from __future__ import annotations

from enum import StrEnum

import sqlalchemy as sa

from daq.vocabulary import RunStatus

metadata = sa.MetaData(
    naming_convention={
        "ix": "ix_%(column_0_label)s",
        "uq": "uq_%(table_name)s_%(column_0_name)s",
        "fk": "fk_%(table_name)s_%(column_0_name)s_%(referred_table_name)s",
        "pk": "pk_%(table_name)s",
    }
)

#: Statuses a run can have; ``running`` only until it ends.
RUN_STATUSES = ("running", "completed", "aborted", "interrupted")
#: Statuses ``finish_run`` accepts.
END_STATUSES = ("completed", "aborted", "interrupted")
#: Where a run's samples came from: recorded on this rig, or imported from a file.
RUN_SOURCES = ("recorded", "imported")
#: What moved the vehicle (``runs.drive``; NULL when nothing did, e.g. a pendulum).
RUN_DRIVES = ("weight", "thrusters")


class JobState(StrEnum):
    """A job's state: ``queued → running ⇄ waiting_for_operator | paused → completed |
    aborted | failed``; ``interrupted`` when its service died while it ran."""

    QUEUED = "queued"
    RUNNING = "running"
    WAITING_FOR_OPERATOR = "waiting_for_operator"
    PAUSED = "paused"
    COMPLETED = "completed"
    ABORTED = "aborted"
    FAILED = "failed"
    INTERRUPTED = "interrupted"


#: States of a job that has not ended.
JOB_ACTIVE = frozenset(
    {JobState.QUEUED, JobState.RUNNING, JobState.WAITING_FOR_OPERATOR, JobState.PAUSED}
)
#: States of a job that has ended.
JOB_FINAL = frozenset(JobState) - JOB_ACTIVE

rigs = sa.Table(
    "rigs",
    metadata,
    sa.Column("id", sa.Integer, primary_key=True),
    sa.Column("name", sa.String(200), nullable=False, unique=True),
)

vehicles = sa.Table(
    "vehicles",
    metadata,
    sa.Column("id", sa.Integer, primary_key=True),
    sa.Column("name", sa.String(200), nullable=False, unique=True),
)

runs = sa.Table(
    "runs",
    metadata,
    sa.Column("id", sa.Integer, primary_key=True),
    sa.Column("uuid", sa.String(36), nullable=False, unique=True),
    sa.Column("kind", sa.String(40), nullable=False, index=True),
    sa.Column("status", sa.String(20), nullable=False, index=True),
    sa.Column("reason", sa.Text, nullable=True),
    sa.Column("parameters", sa.JSON, nullable=False),
    sa.Column("rig_id", sa.ForeignKey("rigs.id"), nullable=False),
    sa.Column("vehicle_id", sa.ForeignKey("vehicles.id"), nullable=False),
    sa.Column("started_at", sa.Float(precision=53), nullable=False, index=True),
    sa.Column("stopped_at", sa.Float(precision=53), nullable=True),
    sa.Column("channel_names", sa.JSON, nullable=False),
    sa.Column("sample_count", sa.BigInteger, nullable=False, server_default="0"),
    sa.Column("software_version", sa.String(100), nullable=False),
    sa.Column("rig_toml", sa.Text, nullable=False),
    sa.Column("scenario_toml", sa.Text, nullable=True),
    sa.Column("owner_host", sa.String(255), nullable=True),
    sa.Column("owner_pid", sa.Integer, nullable=True),
    # Identity of the owner process, so a reused pid or a reboot is not taken for it.
    sa.Column("owner_boot_id", sa.String(64), nullable=True),
    sa.Column("owner_start_ticks", sa.BigInteger, nullable=True),
    # Found and told apart in lists (revision 0003): the drive, where the data came from
    # (an import keeps the original start as started_at), and free metadata (operator,
    # water temperature, notes, tags, any key; see daq.store.run_metadata).
    sa.Column("drive", sa.String(20), nullable=True, index=True),
    sa.Column("source", sa.String(20), nullable=False, server_default="recorded", index=True),
    sa.Column("source_file", sa.String(255), nullable=True),
    sa.Column("imported_at", sa.Float(precision=53), nullable=True),
    sa.Column("metadata", sa.JSON, nullable=True),
    sa.CheckConstraint(
        "status IN ({})".format(", ".join(f"'{s}'" for s in RunStatus)), name="ck_runs_status"
    ),
)

#: The tags of ``runs.metadata`` as rows, so a tag filter is an indexed lookup
#: (written with the metadata, in the same transaction).
run_tags = sa.Table(
    "run_tags",
    metadata,
    sa.Column("run_id", sa.ForeignKey("runs.id", ondelete="CASCADE"), primary_key=True),
    sa.Column("tag", sa.String(40), primary_key=True, index=True),
)

#: A run's samples in blocks (revision 0007): one row per stored batch (merged into larger
#: blocks as the run grows, ``daq.store.samples``), each column a little-endian array
#: (``daq.store.packing``): ``seq`` int64, ``t_mono``/``t_wall`` float64 s, ``quality``
#: int64 flags, ``channel_values`` float64 channel after channel in the run's channel order
#: (``runs.channel_names``); ``stale`` is JSON {index in the block: [stale channel names]}
#: of the samples that had any, NULL when none. Blocks of a run never overlap in seq:
#: ``first_seq``..``last_seq`` bound theirs; ``t_wall_max`` is the latest wall time in it.
sample_blocks = sa.Table(
    "sample_blocks",
    metadata,
    sa.Column("run_id", sa.ForeignKey("runs.id", ondelete="CASCADE"), primary_key=True),
    sa.Column("first_seq", sa.BigInteger, primary_key=True, autoincrement=False),
    sa.Column("last_seq", sa.BigInteger, nullable=False),
    sa.Column("sample_count", sa.Integer, nullable=False),
    sa.Column("level", sa.SmallInteger, nullable=False),
    sa.Column("t_wall_max", sa.Float(precision=53), nullable=True),
    sa.Column("stale", sa.Text, nullable=True),
    sa.Column("seq", sa.LargeBinary, nullable=False),
    sa.Column("t_mono", sa.LargeBinary, nullable=False),
    sa.Column("t_wall", sa.LargeBinary, nullable=False),
    sa.Column("quality", sa.LargeBinary, nullable=False),
    sa.Column("channel_values", sa.LargeBinary, nullable=False),
    sa.Index("ix_sample_blocks_run_id_last_seq", "run_id", "last_seq"),
)

events = sa.Table(
    "events",
    metadata,
    sa.Column("id", sa.Integer, primary_key=True),
    sa.Column("run_id", sa.ForeignKey("runs.id", ondelete="CASCADE"), nullable=True, index=True),
    sa.Column("t_wall", sa.Float(precision=53), nullable=False, index=True),
    sa.Column("kind", sa.String(40), nullable=False),
    sa.Column("message", sa.Text, nullable=False),
    sa.Column("data", sa.JSON, nullable=True),
)

results = sa.Table(
    "results",
    metadata,
    sa.Column("id", sa.Integer, primary_key=True),
    sa.Column("kind", sa.String(40), nullable=False, index=True),
    sa.Column("created_at", sa.Float(precision=53), nullable=False),
    sa.Column("software_version", sa.String(100), nullable=False),
    sa.Column("data", sa.JSON, nullable=False),
)

result_runs = sa.Table(
    "result_runs",
    metadata,
    sa.Column("result_id", sa.ForeignKey("results.id", ondelete="CASCADE"), primary_key=True),
    sa.Column("run_id", sa.ForeignKey("runs.id", ondelete="CASCADE"), primary_key=True, index=True),
)

#: Thrust calibrations brought in from other tools (thrust-stand tables): no run behind
#: them. ``data``: {source, units, table: [{command, thrust_per_thruster_n,
#: supply_voltage_v}]}; the thrust law is identified from the table when used.
thrust_calibrations = sa.Table(
    "thrust_calibrations",
    metadata,
    sa.Column("id", sa.Integer, primary_key=True),
    sa.Column("name", sa.String(200), nullable=False),
    sa.Column("created_at", sa.Float(precision=53), nullable=False, index=True),
    sa.Column("software_version", sa.String(100), nullable=False),
    sa.Column("data", sa.JSON, nullable=False),
)

jobs = sa.Table(
    "jobs",
    metadata,
    sa.Column("id", sa.String(32), primary_key=True),
    sa.Column("rig_name", sa.String(200), nullable=False, index=True),
    sa.Column("kind", sa.String(40), nullable=False),
    sa.Column("label", sa.Text, nullable=False),
    sa.Column("state", sa.String(30), nullable=False, index=True),
    # 1, 2, … for a procedure waiting in the rig's queue; NULL otherwise
    sa.Column("position", sa.Integer, nullable=True),
    # the request a queued procedure is rebuilt from after a restart
    sa.Column("request", sa.JSON, nullable=True),
    sa.Column("parameters", sa.JSON, nullable=False),
    sa.Column("fraction", sa.Float(precision=53), nullable=False, server_default="0"),
    sa.Column("message", sa.Text, nullable=False),
    sa.Column("run_ids", sa.JSON, nullable=False),
    sa.Column("outcome", sa.JSON, nullable=True),
    sa.Column("error", sa.Text, nullable=True),
    sa.Column("result_id", sa.Integer, nullable=True),
    sa.Column("notes", sa.JSON, nullable=False),
    sa.Column("created_at", sa.Float(precision=53), nullable=False, index=True),
    sa.Column("started_at", sa.Float(precision=53), nullable=True),
    sa.Column("finished_at", sa.Float(precision=53), nullable=True),
    sa.Column("owner_host", sa.String(255), nullable=True),
    sa.Column("owner_pid", sa.Integer, nullable=True),
    sa.Column("owner_boot_id", sa.String(64), nullable=True),
    sa.Column("owner_start_ticks", sa.BigInteger, nullable=True),
    # who asked for the job (revision 0006; NULL for older jobs)
    sa.Column("user_name", sa.String(40), nullable=True),
    sa.CheckConstraint(
        "state IN (" + ", ".join(f"'{s.value}'" for s in JobState) + ")", name="ck_jobs_state"
    ),
)

job_events = sa.Table(
    "job_events",
    metadata,
    sa.Column("id", sa.Integer, primary_key=True),
    sa.Column("job_id", sa.ForeignKey("jobs.id", ondelete="CASCADE"), nullable=False, index=True),
    sa.Column("t_wall", sa.Float(precision=53), nullable=False),
    sa.Column("state", sa.String(30), nullable=False),
    sa.Column("fraction", sa.Float(precision=53), nullable=False),
    sa.Column("message", sa.Text, nullable=False),
)

report_files = sa.Table(
    "report_files",
    metadata,
    sa.Column("result_id", sa.ForeignKey("results.id", ondelete="CASCADE"), primary_key=True),
    sa.Column("name", sa.String(200), primary_key=True),
    sa.Column("media_type", sa.String(100), nullable=False),
    sa.Column("content", sa.LargeBinary, nullable=False),
)

#: Roles a named user can have: an operator starts and stops tests, a viewer only reads.
USER_ROLES = ("operator", "viewer")

#: Named users of the API (revision 0006): the token is shown once, only its SHA-256 kept.
users = sa.Table(
    "users",
    metadata,
    sa.Column("id", sa.Integer, primary_key=True),
    sa.Column("name", sa.String(40), nullable=False, unique=True),
    sa.Column("role", sa.String(20), nullable=False),
    sa.Column("token_sha256", sa.String(64), nullable=False, unique=True),
    sa.Column("created_at", sa.Float(precision=53), nullable=False),
    sa.CheckConstraint(
        "role IN (" + ", ".join(f"'{r}'" for r in USER_ROLES) + ")", name="ck_users_role"
    ),
)

#: The rig's safety log (revision 0006): emergency stops, their acknowledgements, holds and
#: releases, each naming who; the latest of each pair is the rig's state.
rig_events = sa.Table(
    "rig_events",
    metadata,
    sa.Column("id", sa.Integer, primary_key=True),
    sa.Column("rig_name", sa.String(200), nullable=False, index=True),
    sa.Column("t_wall", sa.Float(precision=53), nullable=False),
    sa.Column("kind", sa.String(40), nullable=False),
    sa.Column("user_name", sa.String(40), nullable=True),
    sa.Column("message", sa.Text, nullable=False),
)
