// Plots with one row per unit, shared by the live plot (live.js) and the run detail
// (runs.js): each series {x, y, name, label, unit, key} goes in the row of its unit; a row is
// titled by its channel when it holds one, and its y axis steps on 1-2-5 values. Plotly
// itself is loaded with the first plot (withPlotly), not with the page.

// ---- Plotly, on first use ------------------------------------------------------------------
// plotly.js (the full 4.8 MB bundle then) took a headless Chromium about a second of a core
// to compile and run on every page load: a page whose plots are never shown (the
// queue, people, a run list) no longer pays it, and the page is usable before it arrives.
let plotlyLoading = null;
let plotlyReady = false;
/** Calls `draw(Plotly)`: at once once Plotly is loaded, else when it is (calls keep their
 * order); the first call loads /static/vendor/plotly-basic.min.js (app.py PLOTLY_JS). A
 * promise of what `draw` returns. */
export function withPlotly(draw) {
  if (plotlyReady) return Promise.resolve(draw(window.Plotly));
  plotlyLoading ||= new Promise((resolve, reject) => {
    const script = document.createElement("script");
    script.src = "/static/vendor/plotly-basic.min.js";
    script.onload = resolve;
    script.onerror = () => {
      plotlyLoading = null; // the next plot tries again
      reject(new Error("plotly-basic.min.js did not load"));
    };
    document.head.append(script);
  }).then(() => {
    plotlyReady = true;
  });
  return plotlyLoading.then(() => draw(window.Plotly));
}

/** Plotly.newPlot, Plotly.react and Plotly.purge through withPlotly. */
export const newPlot = (...args) => withPlotly((Plotly) => Plotly.newPlot(...args));
export const reactPlot = (...args) => withPlotly((Plotly) => Plotly.react(...args));
// nothing to purge before Plotly drew anything
export const purgePlot = (element) => plotlyLoading && withPlotly((Plotly) => Plotly.purge(element));

// ---- axis ticks --------------------------------------------------------------------------
// A 1-2-5 step giving about `target` intervals over [lo, hi], and a range just beyond the
// outer ticks.
export function niceAxis(lo, hi, target = 5) {
  if (!Number.isFinite(lo) || !Number.isFinite(hi)) return null;
  if (hi - lo < 1e-12) {
    const pad = Math.max(Math.abs(lo) * 0.05, 1e-3);
    lo -= pad;
    hi += pad;
  }
  const raw = (hi - lo) / target;
  const mag = 10 ** Math.floor(Math.log10(raw));
  const step = [1, 2, 5, 10].map((m) => m * mag).find((s) => s >= raw * (1 - 1e-9));
  const decimals = Math.max(0, -Math.floor(Math.log10(step) + 1e-9));
  const [a, b] = [Math.floor(lo / step + 1e-9) * step, Math.ceil(hi / step - 1e-9) * step];
  const margin = 0.04 * (b - a); // the outer ticks stay on 1-2-5 values, lines off the frame
  return {
    range: [a - margin, b + margin],
    dtick: step,
    tickformat: `.${decimals}f`,
  };
}

// ---- rows ------------------------------------------------------------------------------------
const ROW_PX = 190;
const DASHES = ["solid", "dash", "dot", "dashdot"];
const SYMBOLS = ["circle", "square", "diamond", "triangle-up"];

// mode: "lines" against time, "markers" for one channel against another.
export function unitRowsPlot(element, series, { xTitle, empty = "Choose channels above", revision, mode = "lines" } = {}) {
  const units = [...new Set(series.map((s) => s.unit))];
  const rows = Math.max(units.length, 1);
  const gap = 0.06;
  const h = (1 - gap * (rows - 1)) / rows;
  const layout = {
    height: 60 + Math.max(ROW_PX * rows, 300),
    margin: { t: 30, r: 20, b: 45, l: 75 },
    showlegend: true,
    legend: { orientation: "h", x: 0, y: 1.02, yanchor: "bottom" },
    xaxis: { title: { text: xTitle }, anchor: rows > 1 ? `y${rows}` : "y", zeroline: false },
    uirevision: revision,
  };
  const traces = [];
  units.forEach((unit, r) => {
    const axis = r === 0 ? "yaxis" : `yaxis${r + 1}`;
    const ref = r === 0 ? "y" : `y${r + 1}`;
    const inRow = series.filter((s) => s.unit === unit);
    const ys = [];
    for (const [i, s] of inRow.entries()) {
      ys.push(...s.y.filter((v) => v !== null && v !== undefined));
      // equal values stay visible: each line of a row its own dash (marker symbol)
      const look = mode === "lines" ? { line: { dash: DASHES[i % 4] } } : { marker: { size: 4, symbol: SYMBOLS[i % 4] } };
      traces.push({ x: s.x, y: s.y, name: s.name, meta: s.key, mode, yaxis: ref, ...look });
    }
    const labels = [...new Set(inRow.map((s) => s.label))];
    const name = labels.length === 1 ? labels[0] : unit === "fraction" ? "command" : "";
    const top = 1 - r * (h + gap);
    layout[axis] = {
      domain: [Math.max(top - h, 0), top],
      title: { text: unit ? `${name} [${unit}]`.trim() : name || "state" },
      zeroline: false,
    };
    const nice = ys.length ? niceAxis(Math.min(...ys), Math.max(...ys)) : null;
    if (nice) Object.assign(layout[axis], { range: nice.range, tickmode: "linear", tick0: 0, dtick: nice.dtick, tickformat: nice.tickformat });
  });
  if (!units.length) {
    layout.annotations = [{ text: empty, showarrow: false, xref: "paper", yref: "paper", x: 0.5, y: 0.5, font: { size: 14 } }];
    layout.xaxis.visible = false;
    layout.yaxis = { visible: false };
    layout.height = 300;
  }
  return withPlotly((Plotly) => Plotly.react(element, traces, layout, { responsive: true, displaylogo: false }));
}
