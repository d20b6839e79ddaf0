// Values as the pages print them, no DOM (unit-tested with node --test): numbers to a few
// significant digits, API times in the reader's local time, a calibration's supply voltages.
/** A number to `digits` significant digits without trailing noise ("0.285", not
 * "0.28500000000000003"); "—" for none; anything else as its text. */
export function fmt(v, digits = 4) {
  if (v === null || v === undefined) return "—";
  return typeof v === "number" ? Number(v.toPrecision(digits)).toString() : String(v);
}

/** The reader's time zone (IANA name): the API takes days in it. */
export const TIME_ZONE = Intl.DateTimeFormat().resolvedOptions().timeZone;

/** A time the API gives (ISO 8601, UTC) as the reader's local date and time; "—" for none. */
export function localTime(iso) {
  return iso ? new Date(iso).toLocaleString() : "—";
}

/** A calibration's supply voltages [V] once: the steps' readings are noisy
 * ("15.711000000000002, 15.69…"), so one value to 0.1 V, or the range when they differ by
 * 0.15 V or more; "" for none. */
export function voltageText(volts) {
  const v = (volts || []).filter((x) => typeof x === "number" && Number.isFinite(x));
  if (!v.length) return "";
  const lo = Math.min(...v);
  const hi = Math.max(...v);
  if (hi - lo < 0.15) return `${((lo + hi) / 2).toFixed(1)} V`;
  return `${lo.toFixed(1)}–${hi.toFixed(1)} V`;
}

/** A live reading with its unit to `digits` significant digits ("15.7 V", "2480 rpm",
 * "-3.2 A"); "—" for none or a value that is not a finite number. */
export function reading(v, unit, digits = 3) {
  if (typeof v !== "number" || !Number.isFinite(v)) return "—";
  return `${fmt(v, digits)} ${unit}`;
}
