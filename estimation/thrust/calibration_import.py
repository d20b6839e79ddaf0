"""Thrust-stand calibration tables from other tools: a CSV with a command column, a thrust
column and optionally a supply-voltage column, each in its own unit, and the electrical and
shaft columns a thrust stand logs beside them (current A, RPM, electrical power W).

Read as every imported table is (``estimation.data.csv_dialect``): the separator (``,``
``;`` tab) sniffed, Excel's UTF-8 byte-order mark dropped, lines starting with ``#``
comments, and with a ``;`` or tab separator a decimal comma read as a point. Commands
become the rig's fractions of full command (−1 … 1), thrust newtons.
"""

from __future__ import annotations

import csv
import math
from dataclasses import dataclass

from estimation.data.csv_dialect import BOM, TableDialect, decode_table, sniff_dialect

#: Newtons per unit of thrust.
THRUST_UNITS: dict[str, float] = {
    "N": 1.0,
    "kgf": 9.80665,
    "gf": 9.80665e-3,
    "lbf": 4.4482216152605,
}
#: Command units: the command is turned into a fraction of full command.
COMMAND_UNITS: tuple[str, ...] = ("pwm_us", "permille", "fraction", "volts")
#: Stand channels kept beside thrust: row key → header names that name it (case-insensitive),
#: each in the unit of its key (A, rev/min, W). A header not listed is named with
#: ``ImportSpec.extra_columns``.
STAND_COLUMNS: dict[str, tuple[str, ...]] = {
    "current_a": ("current (a)", "current_a", "current [a]", "current"),
    "rpm": ("rpm", "speed (rpm)", "rpm (rev/min)"),
    "power_w": ("power (w)", "power_w", "power [w]", "power", "electrical power (w)"),
}
#: The unit of every stand channel a row may carry (the derived efficiency included).
STAND_UNITS: dict[str, str] = {
    "current_a": "A",
    "rpm": "rev/min",
    "power_w": "W",
    "efficiency_n_per_w": "N/W",
}
#: Commands of a PWM table (µs): a ``fraction`` column entirely inside this range is PWM.
PWM_RANGE_US = (500.0, 2500.0)


@dataclass(frozen=True)
class CommandUnit:
    """How a command column maps to a fraction: PWM (µs − neutral) / span, ‰ / 1000, a
    fraction as is, volts / full_scale_v."""

    unit: str = "fraction"
    pwm_neutral_us: float = 1500.0
    pwm_span_us: float = 400.0
    full_scale_v: float | None = None

    def __post_init__(self) -> None:
        if self.unit not in COMMAND_UNITS:
            raise ValueError(
                f"command_unit: got {self.unit!r}, allowed: {', '.join(COMMAND_UNITS)}"
            )
        if not self.pwm_span_us > 0:
            raise ValueError(f"pwm_span_us: got {self.pwm_span_us:g}, allowed: > 0")
        if self.unit == "volts" and not (self.full_scale_v and self.full_scale_v > 0):
            raise ValueError(
                "full_scale_v: a command in volts needs the full-scale command voltage (> 0)"
            )

    def fraction(self, value: float) -> float:
        """The command as a fraction of full command."""
        if self.unit == "pwm_us":
            return (value - self.pwm_neutral_us) / self.pwm_span_us
        if self.unit == "permille":
            return value / 1000.0
        if self.unit == "volts":
            assert self.full_scale_v is not None
            return value / self.full_scale_v
        return value

    def to_json(self) -> dict:
        return {
            "unit": self.unit,
            "pwm_neutral_us": self.pwm_neutral_us,
            "pwm_span_us": self.pwm_span_us,
            "full_scale_v": self.full_scale_v,
        }


@dataclass(frozen=True)
class ImportSpec:
    """Which columns hold what, and in which unit. A column is named by its header text
    (surrounding blanks ignored, case-insensitive) or its 1-based number."""

    command_column: str
    thrust_column: str
    thrust_unit: str = "N"
    command: CommandUnit = CommandUnit()
    voltage_column: str | None = None
    #: Supply voltage of every row when the table has no voltage column (None: not known).
    voltage_v: float | None = None
    #: Stand columns by row key (``current_a``, ``rpm``, ``power_w``) → header or number;
    #: a key not given is read from a column whose header names it (``STAND_COLUMNS``).
    extra_columns: tuple[tuple[str, str], ...] = ()

    def __post_init__(self) -> None:
        for key, _ in self.extra_columns:
            if key not in STAND_COLUMNS:
                raise ValueError(f"extra_columns: got {key!r}, allowed: {', '.join(STAND_COLUMNS)}")
        if self.thrust_unit not in THRUST_UNITS:
            raise ValueError(
                f"thrust_unit: got {self.thrust_unit!r}, allowed: {', '.join(THRUST_UNITS)}"
            )
        if self.voltage_v is not None and not (0 < self.voltage_v <= 1000):
            raise ValueError(f"voltage_v: got {self.voltage_v:g}, allowed: 0 < V ≤ 1000")


def stand_columns(**named: str | None) -> tuple[tuple[str, str], ...]:
    """``ImportSpec.extra_columns`` from keyword arguments (``current_a="I (A)"``), the
    ``None`` ones left out."""
    return tuple((key, column) for key, column in named.items() if column is not None)


def _lines(text: str) -> list[tuple[int, str]]:
    return [
        (n, line)
        for n, line in enumerate(text.splitlines(), start=1)
        if line.strip() and not line.lstrip().startswith("#")
    ]


def _column(header: list[str], wanted: str, flag: str) -> int:
    names = [h.strip().lower() for h in header]
    key = wanted.strip().lower()
    if key in names:
        return names.index(key)
    if key.isdigit() and 1 <= int(key) <= len(header):
        return int(key) - 1
    raise ValueError(
        f"{flag}: no column {wanted!r}; the table has {', '.join(repr(h.strip()) for h in header)}"
    )


def _stand_columns(header: list[str], spec: ImportSpec) -> dict[str, int]:
    """Row key → column index of the stand channels the table has (named or recognised)."""
    named = dict(spec.extra_columns)
    found = {key: _column(header, wanted, f"{key}_column") for key, wanted in named.items()}
    names = [h.strip().lower() for h in header]
    for key, aliases in STAND_COLUMNS.items():
        if key not in found:
            hit = next((names.index(a) for a in aliases if a in names), None)
            if hit is not None:
                found[key] = hit
    return found


def _pwm_hint(spec: ImportSpec, cell: str, dialect: TableDialect) -> str:
    """``; use command_unit pwm_us`` when a fraction column holds PWM microseconds."""
    if spec.command.unit != "fraction":
        return ""
    try:
        value = dialect.number(cell)
    except ValueError:
        return ""
    lo, hi = PWM_RANGE_US
    if lo <= value <= hi:
        return (
            f"; {value:g} looks like a PWM pulse in µs: use command_unit pwm_us "
            f"(neutral {spec.command.pwm_neutral_us:g} µs, span {spec.command.pwm_span_us:g} µs)"
        )
    return ""


def _stand_values(
    row: list[str], columns: dict[str, int], header: list[str], dialect: TableDialect, line: int
) -> dict[str, float]:
    """The stand channels of one row (blank cells left out)."""
    out = {}
    for key, i in columns.items():
        if i < len(row) and row[i].strip():
            out[key] = _number(row[i], dialect, header[i].strip(), line)
    return out


def efficiency_n_per_w(row: dict) -> float | None:
    """Thrust per electrical watt, N/W: |F| / P, with P the power column or V·I; None
    without a positive power."""
    power = row.get("power_w")
    if power is None and row.get("current_a") is not None and row.get("supply_voltage_v"):
        power = row["current_a"] * row["supply_voltage_v"]
    if power is None or not power > 0:
        return None
    return abs(row["thrust_per_thruster_n"]) / power


def _number(cell: str, dialect: TableDialect, column: str, line: int) -> float:
    try:
        value = dialect.number(cell)
    except ValueError:
        raise ValueError(
            f"line {line}, column {column!r}: got {cell!r}, allowed: a number"
        ) from None
    if not math.isfinite(value):
        raise ValueError(f"line {line}, column {column!r}: got {cell!r}, allowed: a finite number")
    return value


def read_calibration_csv(data: bytes | str, spec: ImportSpec) -> list[dict]:
    """Rows ``{command, thrust_per_thruster_n, supply_voltage_v}`` (command a fraction, thrust
    N, voltage V or None) from a CSV table, plus ``current_a``, ``rpm``, ``power_w`` where the
    table has them and ``efficiency_n_per_w`` = |F| / P (P the power column, else V·I);
    ``ValueError`` names the column and line."""
    if isinstance(data, bytes):
        data = decode_table(data)
    data = data.removeprefix(BOM)
    lines = _lines(data)
    if len(lines) < 2:
        raise ValueError("file: allowed a header line and at least one row of numbers")
    dialect = sniff_dialect(line for _, line in lines)
    rows = list(csv.reader((line for _, line in lines), delimiter=dialect.delimiter))
    header, numbers = rows[0], rows[1:]
    ci = _column(header, spec.command_column, "command_column")
    ti = _column(header, spec.thrust_column, "thrust_column")
    vi = (
        None
        if spec.voltage_column is None
        else _column(header, spec.voltage_column, "voltage_column")
    )
    names = {i: header[i].strip() for i in (ci, ti, vi) if i is not None}
    stand = {k: i for k, i in _stand_columns(header, spec).items() if i not in names}
    scale = THRUST_UNITS[spec.thrust_unit]
    out = []
    for (line, _), row in zip(lines[1:], numbers, strict=True):
        for i in names:
            if i >= len(row) or not row[i].strip():
                raise ValueError(f"line {line}, column {names[i]!r}: empty, allowed: a number")
        command = spec.command.fraction(_number(row[ci], dialect, names[ci], line))
        if not -1.0 - 1e-9 <= command <= 1.0 + 1e-9:
            raise ValueError(
                f"line {line}, column {names[ci]!r}: got {row[ci].strip()}, allowed: "
                f"a command within full reverse … full forward ({spec.command.unit})"
                + _pwm_hint(spec, row[ci], dialect)
            )
        volts = spec.voltage_v
        if vi is not None:
            volts = _number(row[vi], dialect, names[vi], line)
            if not 0 < volts <= 1000:
                raise ValueError(
                    f"line {line}, column {names[vi]!r}: got {volts:g}, allowed: 0 < V ≤ 1000"
                )
        entry: dict = {
            "command": round(command, 12),
            "thrust_per_thruster_n": _number(row[ti], dialect, names[ti], line) * scale,
            "supply_voltage_v": volts,
        } | _stand_values(row, stand, header, dialect, line)
        efficiency = efficiency_n_per_w(entry)
        if efficiency is not None:
            entry["efficiency_n_per_w"] = efficiency
        out.append(entry)
    return out
