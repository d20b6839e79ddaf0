// The run detail's plot as data, no DOM (runs.js draws it with plots.js): the chosen channels
// of one or more runs against time from each run's release, or against another channel
// ("Y against X", e.g. thrust against RPM), each line named by its channel and, when runs
// are overlaid, by its run. Unit-tested without a browser (tests/api/static/*.test.js).

// The x axis of a run plot when no channel is chosen for it.
export const TIME_AXIS = "time";

/**
 * A channel as the plots name it: "drive_force" → "drive force"; a thruster's telemetry
 * by what it measures, its unit shown beside it: "thruster1_rpm" → "thruster 1 speed",
 * "thruster2_current" → "thruster 2 current".
 */
export function channelLabel(name) {
  const telemetry = /^thruster(\d+)_(rpm|current)$/.exec(String(name));
  if (telemetry) return `thruster ${telemetry[1]} ${telemetry[2] === "rpm" ? "speed" : "current"}`;
  return String(name).replace(/_/g, " ");
}

/** A unit as an axis prints it: "" for none or the dimensionless "1". */
export function shownUnit(unit) {
  return unit === "1" ? "" : unit || "";
}

/** An axis title or legend entry: "drive force [N]", or the bare label without a unit. */
export function withUnit(label, unit) {
  return unit ? `${label} [${unit}]` : label;
}

/** A run as a legend names it: short id, kind and load, e.g. "3f2a9c1e tow 30 N". */
export function runName(run, loadText = "") {
  return [String(run.id).slice(0, 8), run.kind, loadText].filter(Boolean).join(" ");
}

/**
 * The series of a run plot (plots.js `unitRowsPlot`) and its x-axis title.
 * runs: [{run, samples: {t_mono [s], channels, units}, release: t_mono [s] or null, name}];
 * channels: the y channels; x: TIME_AXIS or a channel name. With time on x each run starts
 * at its release (at its first sample when any run has none). A run without the x channel
 * is left out and listed in `missing` by name.
 */
export function runPlotSeries(runs, channels, x = TIME_AXIS) {
  const series = [];
  const missing = [];
  const byTime = x === TIME_AXIS;
  const fromRelease = runs.every((r) => r.release !== null && r.release !== undefined);
  let xTitle = fromRelease ? "time from release [s]" : "time from first sample [s]";
  if (!byTime) {
    const owner = runs.find((r) => x in r.samples.channels);
    xTitle = withUnit(channelLabel(x), owner ? shownUnit(owner.samples.units[x]) : "");
  }
  for (const r of runs) {
    const s = r.samples;
    let xs;
    if (byTime) {
      const t0 = fromRelease ? r.release : s.t_mono[0];
      xs = s.t_mono.map((t) => t - t0);
    } else if (x in s.channels) {
      xs = s.channels[x];
    } else {
      missing.push(r.name);
      continue;
    }
    for (const k of channels) {
      if (!(k in s.channels) || k === x) continue;
      const unit = shownUnit(s.units[k]);
      const label = channelLabel(k);
      const who = runs.length > 1 ? ` · ${r.name}` : "";
      series.push({ x: xs, y: s.channels[k], name: `${withUnit(label, unit)}${who}`, label, unit, key: `${r.run.id}:${k}` });
    }
  }
  return { series, xTitle, mode: byTime ? "lines" : "markers", missing };
}
