"""A run's stored parameters as people read them: a label and a unit for each, from the
key's SI suffix (``max_distance_m`` → "max distance", m), so a new parameter is labelled
without an entry here; the few keys whose words are not their name are listed.

    >>> [p.text for p in labelled({"force_n": 24.5, "hung_mass_kg": 2.5, "requested": None})]
    ['force 24.5 N', 'hung weight 2.5 kg']
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

#: Key suffix → unit (SI, as the code stores it), longest suffixes first.
SUFFIX_UNITS: tuple[tuple[str, str], ...] = (
    ("_kgm2", "kg·m²"),
    ("_nm", "N·m"),
    ("_kg", "kg"),
    ("_rad", "rad"),
    ("_hz", "Hz"),
    ("_us", "µs"),
    ("_n", "N"),
    ("_m", "m"),
    ("_s", "s"),
    ("_v", "V"),
    ("_c", "°C"),
)
#: Keys whose label is not their name's words.
LABELS: dict[str, str] = {
    "hung_mass_kg": "hung weight",
    "baseline_s": "at rest before release",
    "settle_s": "settling per step",
    "commands": "commands (fraction of full)",
    "sweep": "sweep order (fraction of full)",
    "requested": "asked for",
}
#: Keys that say what the run is rather than how it ran (shown elsewhere).
HIDDEN = frozenset({"kind"})


@dataclass(frozen=True)
class Parameter:
    """One parameter: its key, label, value and unit ("" for a count, a word or a flag)."""

    key: str
    label: str
    value: Any
    unit: str

    @property
    def shown(self) -> str:
        """The value as people read it, with its unit: ``4.2 m``."""
        return _value_text(self.value) + (f" {self.unit}" if self.unit else "")

    @property
    def text(self) -> str:
        """``max distance 4.2 m``."""
        return f"{self.label} {self.shown}"

    def to_json(self) -> dict[str, Any]:
        return {
            "key": self.key,
            "label": self.label,
            "value": self.value,
            "unit": self.unit,
            "shown": self.shown,
        }


def split_key(key: str) -> tuple[str, str]:
    """``("max distance", "m")`` for ``max_distance_m``; a key without a unit suffix keeps
    its words and no unit."""
    for suffix, unit in SUFFIX_UNITS:
        if key.endswith(suffix) and len(key) > len(suffix):
            return LABELS.get(key, key[: -len(suffix)].replace("_", " ")), unit
    return LABELS.get(key, key.replace("_", " ")), ""


def _value_text(value: Any) -> str:
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, float):
        return f"{value:.6g}"
    if isinstance(value, list | tuple):
        return ", ".join(_value_text(v) for v in value)
    return str(value)


def labelled(parameters: dict[str, Any]) -> list[Parameter]:
    """The parameters that were set (``None`` left out), labelled, in stored order; a nested
    mapping (``requested``) becomes one parameter whose value reads ``force 24.5 N``."""
    out = []
    for key, value in parameters.items():
        if value is None or key in HIDDEN:
            continue
        label, unit = split_key(key)
        if isinstance(value, dict):
            value = "; ".join(p.text for p in labelled(value))
        out.append(Parameter(key, label, value, unit))
    return out
