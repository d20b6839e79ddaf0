"""Stored runs as the estimators see them (``estimation.data.run_arrays.RunData``, and
``estimation.pendulum.data.PendulumRun`` for pendulum free-decay runs).

The bridge between storage and estimation: picks the position channel of the
axis, the time base, the release and brake instants from the run's events, and
the drive (force or torque, hung weight, drive-train inertia) from its parameters
and the rig file it ran with. ``estimation`` itself never imports this.

Tow, spin and pendulum runs share the time base and the release/end instants
(``_timeline``); the drive of a thruster-driven run is rebuilt by ``daq.thruster_run_drive``.
What differs per kind is read from its axis words (``daq.vocabulary.AXES``: position
channel, release coil, end switch, drive key and drive train), never branched on its name.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from daq.config import RigConfig, RigConfigError, parse_rig_text
from daq.fit_exclusions import left_out, trusted_samples
from daq.store import RunInfo, SampleTable, Store
from daq.store.run_events import Gap, RunAction, RunEvents
from daq.vocabulary import AXES, POSITION_CHANNEL, Axis, DriveTrain
from estimation.data.run_arrays import RunData
from estimation.data.window import WindowReport, find_window
from estimation.pendulum.data import PendulumGeometry, PendulumRun


def _rig_of(run: RunInfo) -> RigConfig | None:
    """The rig file the run was recorded with (None for imported data without one)."""
    if not run.rig_toml:
        return None
    try:
        return parse_rig_text(run.rig_toml, f"run {run.id} rig file")
    except RigConfigError as err:
        raise ValueError(f"run {run.id}: its stored rig file is unreadable: {err}") from None


@dataclass(frozen=True)
class _Timeline:
    """A run's time base and its release (and end) instants on it."""

    t: np.ndarray  # s, the good samples' times
    good: np.ndarray  # mask of the good samples in the stored table
    t_release: float
    t_release_std: float
    t_end: float | None
    offset: float  # host monotonic time + offset = the time base
    events: RunEvents  # the run's stored events
    #: How the release/end were known ("release event", "release_time_s", …); None: not
    #: recorded (the release defaults to the first sample, the end to the last).
    release_source: str | None = None
    end_source: str | None = None
    #: The samples left out (value or time untrusted: ``daq.sample_losses``), host times.
    gaps: tuple[Gap, ...] = ()


def _timeline(
    store: Store,
    run: RunInfo,
    rig: RigConfig | None,
    table: SampleTable,
    channel: str,
    *,
    end: RunAction,
) -> _Timeline:
    """Time base of the samples where ``channel`` is good, and the release/end instants.

    The PLC's own clock when the run has it (device-side timestamps, free of host
    scheduling jitter), else the host's monotonic time. Host instants from the events
    (the release, the ``end`` event's last free sample) are mapped onto it with the host/PLC
    offset of the least-delayed samples; ``t_release_std`` combines the write's bracket,
    the offset's spread and the clock's step.
    """
    clock = table.channels.get("plc_clock")
    good, gaps = trusted_samples(table, channel, device_clock=clock is not None)
    if clock is not None and not (
        np.all(np.isfinite(clock[good])) and np.all(np.diff(clock[good]) > 0)
    ):
        clock = None  # the host's time base: a late slot's time stamp is not trusted
        good, gaps = trusted_samples(table, channel, device_clock=False)
    t_host = table.t_mono[good]
    t = t_host
    clock_step = 0.0
    if clock is not None:
        t = clock[good]
        # One count of the PLC clock (the rig file's scale; ms on BENBAM).
        clock_step = abs(rig.channel("plc_clock").scale) if rig is not None else 1e-3
    # Map host instants (release, brake, thrust steps) onto the chosen time base. A sample's
    # host time is stamped when its reply arrived, i.e. late by the poll's latency, which is
    # never negative and grows under CPU load: the least-delayed samples (the top tenth of
    # PLC − host) give the offset, as the minimum-delay filter of clock synchronisation
    # does. The median would put host events early by the typical latency.
    gap = t - t_host
    offset = float(np.mean(np.sort(gap)[-max(1, gap.size // 10) :])) if t.size else 0.0
    offset_spread = 1.4826 * float(np.median(np.abs(gap - np.median(gap)))) if t.size else 0.0
    events = RunEvents.of(store.events(run.id))
    t_release = events.release_time
    halt = events.halt(end)
    t_stop = None if halt is None else halt.t_last_free
    release_source = end_source = None
    if t_release is not None:
        release_source = "release event"
    elif run.parameters.get("release_time_s") is not None:  # given at import
        t_release = float(table.t_mono[0]) + float(run.parameters["release_time_s"])
        release_source = "release_time_s (given)"
    if t_stop is not None:
        end_source = f"{end} event"
    elif run.parameters.get("end_time_s") is not None:
        t_stop = float(table.t_mono[0]) + float(run.parameters["end_time_s"])
        end_source = "end_time_s (given)"
    if t_release is None:  # imported data: the release is somewhere in the first period
        t_release = float(t[0]) if t.size else 0.0
        t_release_std = float(np.median(np.diff(t))) / np.sqrt(12) if t.size > 1 else 0.0
    else:
        # The brake let go while the write was in flight (± half-width, uniform), mapped
        # onto the time base with the spread of the host/PLC offset and the clock's step.
        half_width = events.release.t_half_width if events.release is not None else 0.0
        t_release += offset
        t_release_std = float(np.sqrt(half_width**2 / 3 + offset_spread**2 + clock_step**2 / 12))
    t_end = None if t_stop is None else t_stop + offset
    # a release given at import may precede the record (it starts with the body moving)
    earliest = -math.inf if release_source == "release_time_s (given)" else float(t[0])
    t_release = min(max(t_release, earliest), float(t[-1])) if t.size else 0.0
    return _Timeline(
        np.asarray(t, dtype=float),
        good,
        t_release,
        t_release_std,
        t_end,
        offset,
        events,
        release_source,
        end_source,
        gaps,
    )


def load_run_data(store: Store, run_id: str) -> RunData:
    """Build the estimator's view of one stored tow or spin run (:func:`run_data_of` of its
    record)."""
    return run_data_of(store, store.get_run(run_id))


def run_data_of(store: Store, run: RunInfo) -> RunData:
    """The estimator's view of the stored tow or spin run ``run`` (its record, read once by
    the estimate: ``api.core.estimation_job.stored_runs``); its samples and events from
    ``store``.

    Time base as ``_timeline`` picks it. Raises ``ValueError`` naming the run when it
    cannot be estimated.
    """
    if run.kind not in POSITION_CHANNEL:
        raise ValueError(f"run {run.id}: kind {run.kind!r} cannot be estimated; allowed: tow, spin")
    rig = _rig_of(run)
    table = store.samples(run.id)
    channel = POSITION_CHANNEL[run.kind]
    if channel not in table.channels and "position" in table.channels:
        channel = "position"
    if channel not in table.channels:
        raise ValueError(f"run {run.id}: no {POSITION_CHANNEL[run.kind]!r} channel in its samples")
    timeline = _timeline(store, run, rig, table, channel, end=RunAction.BRAKE)
    t, position = timeline.t, table.channels[channel][timeline.good]
    params = run.parameters
    keep, window, t_release_std = _window(run, table, timeline, position)
    window = replace(
        window,
        left_out=left_out(run, table, timeline.gaps, timeline.offset, window, int(keep.sum())),
    )
    t, position = t[keep], position[keep]
    t_release, t_end = window.t_release, window.t_end
    if t_release_std is None:
        t_release_std = timeline.t_release_std

    thrusters = params.get("drive") == "thrusters"
    drive_inertia, drum_radius = _drive_train(rig, AXES[run.kind].drive_train, thrusters)
    name = str(AXES[run.kind].drive_key)
    drive = params.get(name)
    logged = _logged_drive(run, table, timeline.good)
    if logged is not None:
        drive = logged[keep]
    elif drive is None or not math.isfinite(float(drive)):
        raise ValueError(f"run {run.id}: no applied {name} in its parameters")
    hung = params.get("hung_mass_kg")
    draws = None
    if thrusters:
        # the thrust law (SciPy's interpolation): imported for thruster-driven runs only
        from daq.thruster_run_drive import confirmed_steps, modelled_steps, rebuilt_thruster_drive

        if rig is None:
            raise ValueError(f"run {run.id}: a thruster-driven run needs the rig file it ran with")
        volts = table.channels.get("supply_voltage")
        steps = confirmed_steps(timeline.events, timeline.offset)
        drive, draws, drive_law = rebuilt_thruster_drive(
            store,
            rig,
            run.id,
            run.kind,
            params,
            t,
            steps or modelled_steps(rig, params["commands"], t, t_release),
            None if volts is None else volts[timeline.good][keep],
        )
    return RunData(
        run_id=run.id,
        axis="surge" if AXES[run.kind].axis.value == "surge" else "yaw",
        t=np.asarray(t, dtype=float),
        position=np.asarray(position, dtype=float),
        drive=drive if isinstance(drive, np.ndarray) else float(drive),
        hung_mass_kg=float(hung) if hung else None,
        drive_inertia=drive_inertia,
        drum_radius_m=drum_radius,
        t_release=t_release,
        t_end=t_end,
        t_release_std=t_release_std,
        drive_draws=draws,
        window_found=window,
        drive_law=drive_law if thrusters else None,
        dof=params.get("dof"),  # a tow imported as heave or sway (``rig import --dof``)
    )


def _drive_train(
    rig: RigConfig | None, train: DriveTrain | None, thrusters: bool
) -> tuple[float, float | None]:
    """The drive train's inertia in axis units (J/r², kg, on a linear axis; J, kg·m²,
    otherwise) and the drum radius a hung weight acts at (``None`` on a linear axis): from
    the axis's ``DriveTrain`` and the rig file's geometry; 0 without a rig file, or when the
    thrusters drive and the train is unhooked."""
    if rig is None or train is None or (thrusters and not train.turns_with_thrusters):
        return 0.0, None
    inertia = float(getattr(rig.geometry, train.inertia_key))
    radius = getattr(rig.geometry, train.radius_key)
    if train.linear:
        return inertia / float(radius) ** 2, None
    return inertia, radius


def _logged_drive(run: RunInfo, table: SampleTable, good: np.ndarray) -> np.ndarray | None:
    """The drive logged per sample (an imported run's ``drive_channel``) at the good
    samples; None when the run has a constant drive."""
    channel = run.parameters.get("drive_channel")
    if channel is None:
        return None
    values = table.channels.get(channel)
    if values is None:
        raise ValueError(f"run {run.id}: no {channel!r} channel (its logged drive) in its samples")
    values = np.asarray(values[good], dtype=float)
    if not np.all(np.isfinite(values)):
        raise ValueError(f"run {run.id}: its logged drive {channel!r} has samples missing")
    return values


def _window(
    run: RunInfo, table: SampleTable, timeline: _Timeline, position: np.ndarray
) -> tuple[np.ndarray, WindowReport, float | None]:
    """The samples to fit and how the window was found (``estimation.data.window``): the
    recorded events or given times first, then the run's own coil/switch channels, then
    the motion itself. Returns (mask of the good samples kept, report, release σ or None
    when the timeline's own applies)."""

    def channel(name: str) -> np.ndarray | None:
        values = table.channels.get(name)
        if values is None:
            return None
        values = values[timeline.good]
        return values if np.all(np.isfinite(values)) else None

    terms = AXES[run.kind]
    force = run.parameters.get(str(terms.drive_key))
    logged = _logged_drive(run, table, timeline.good)
    if logged is not None:
        force = float(np.mean(logged)) if logged.size else None
    direction = float(np.sign(float(force))) if force is not None else 0.0
    keep, report, std = find_window(
        timeline.t,
        position,
        direction=direction,
        release_coil=channel(terms.release_coil),
        end_switch=None if terms.end_switch is None else channel(terms.end_switch),
        t_release=timeline.t_release if timeline.release_source else None,
        release_source=timeline.release_source or "",
        t_end=timeline.t_end if timeline.end_source else None,
        end_source=timeline.end_source or "",
    )
    return keep, report, std


def pendulum_geometry(rig: RigConfig) -> PendulumGeometry:
    """The estimator's pendulum geometry from a rig file's ``[pendulum]`` and ``[vehicle]``."""
    p = rig.pendulum
    if p is None:
        raise ValueError(f"rig {rig.rig.name!r}: no [pendulum] section in its rig file")
    return PendulumGeometry(
        pivot_to_vehicle_m=p.pivot_to_vehicle_m,
        rod_mass_kg=p.rod_mass_kg,
        rod_cg_m=p.rod_cg_m,
        rod_inertia_kg_m2=p.rod_inertia_kg_m2,
        vehicle_mass_kg=rig.vehicle.dry_mass_kg,
        vehicle_inertia_kg_m2=p.vehicle_inertia_kg_m2,
        buoyancy_kg=p.buoyancy_kg,
        pivot_damping_nm_s=p.pivot_damping_nm_s,
        g=rig.rig.g,
    )


def load_pendulum_data(store: Store, run_id: str) -> PendulumRun:
    """Build the estimator's view of one stored pendulum free-decay run
    (:func:`pendulum_data_of` of its record)."""
    return pendulum_data_of(store, store.get_run(run_id))


def pendulum_data_of(store: Store, run: RunInfo) -> PendulumRun:
    """The estimator's view of the stored pendulum free-decay run ``run`` (its record, read
    once by the estimate); its samples and events from ``store``.

    The geometry comes from the rig file stored with the run, the angle from its
    ``pendulum_angle`` channel, the time base and release instant as for a tow
    (``_timeline``). Samples after the catch (the pendulum held still) are left out.
    Raises ``ValueError`` naming the run when it cannot be estimated.
    """
    terms = AXES.get(run.kind)
    if terms is None or terms.axis != Axis.SWING:  # the pendulum's swing, whatever its kind
        raise ValueError(f"run {run.id}: kind {run.kind!r} is not a pendulum free-decay run")
    rig = _rig_of(run)
    if rig is None or rig.pendulum is None:
        raise ValueError(
            f"run {run.id}: the rig file it ran with has no [pendulum] section (geometry unknown)"
        )
    table = store.samples(run.id)
    channel = terms.position_channel
    if channel not in table.channels:
        raise ValueError(f"run {run.id}: no {channel!r} channel in its samples")
    timeline = _timeline(store, run, rig, table, channel, end=RunAction.CATCH)
    t, angle = timeline.t, table.channels[channel][timeline.good]
    catch = timeline.events.catch
    if catch is not None and catch.seq is not None:
        free = table.seq[timeline.good] <= catch.seq
        t, angle = t[free], angle[free]
    elif timeline.t_end is not None:  # an imported decay's end_time_s
        t, angle = t[t <= timeline.t_end], angle[t <= timeline.t_end]
    return PendulumRun(
        run_id=run.id,
        t=t,
        angle=np.asarray(angle, dtype=float),
        t_release=timeline.t_release,
        geometry=pendulum_geometry(rig),
        axis=rig.pendulum.axis,
        t_release_std=timeline.t_release_std,
    )
