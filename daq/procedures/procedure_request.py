"""What every procedure request shares: which rig-file limit bounds a field
(:class:`RigLimit`), which field the rig check requires (:class:`RequiredByCheck`), the
strict base model with the run's metadata (``RunMetadataIn``, its fields made from the
known keys of ``daq.store.run_metadata.KNOWN`` by :func:`metadata_key_fields`, as the
metadata options' are), and the rig in the validation context (:func:`rig_of`). How a
field is spelled on the command line is ``daq.procedures.flag``; the kinds' models are in
``daq.procedures.requests``.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Annotated, Any, ClassVar, Literal, Self, TypeVar

from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    PrivateAttr,
    ValidationError,
    ValidationInfo,
    create_model,
    field_validator,
    model_validator,
)

from daq.procedures import params as p
from daq.procedures.flag import Flag
from daq.procedures.params import ParameterError
from daq.store import run_metadata
from daq.store.run_metadata import MAX_TAGS

if TYPE_CHECKING:
    from pydantic import ModelWrapValidatorHandler

    from daq.config import RigConfig
    from daq.vocabulary import RunKind


@dataclass(frozen=True)
class RigLimit:
    """The rig-file limit bounding a request field: ``highest(rig)`` (``None``: the rig file
    sets none), and with ``signed`` the field may be as negative (a reverse test: −max … max).

    Declared once on the field (``Annotated[..., RigLimit(lambda rig: rig.limits.max_force_n,
    signed=True)]``): the field's validator checks it, a thruster drive is scanned up to it
    (``daq.procedures.drive_check``) and ``GET /api/rig`` serves it per kind and field
    (``field_limits``) as the browser's inputs' ``max`` (and ``min``)."""

    highest: Callable[[RigConfig], float | None]
    signed: bool = False
    #: The rig file's setting the limit is (``max_force_n``), named in a refusal; ``None``:
    #: the limit is worked out from several.
    setting: str | None = None

    @classmethod
    def of_setting(cls, path: str, *, signed: bool = False) -> RigLimit:
        """The limit is the rig file's setting ``path`` (``"limits.max_force_n"``)."""
        section, name = path.split(".")
        return cls(lambda rig: getattr(getattr(rig, section), name), signed, name)


@dataclass(frozen=True)
class RequiredByCheck:
    """The field must be given although its default is ``None``: the rig check
    (:meth:`ProcedureRequest.checked`) refuses it missing, naming the range the rig allows
    (a model-required field would be refused before that, with no range). Declared once on
    the field (``Annotated[float | None, …, RequiredByCheck()]``): its validator reads it
    (:func:`required_by_check`) and the docs' option lists show its option unbracketed."""


def required_by_check(model: type[BaseModel], name: str) -> bool:
    """Whether field ``name`` of ``model`` carries :class:`RequiredByCheck`."""
    return any(isinstance(m, RequiredByCheck) for m in model.model_fields[name].metadata)


def comma_separated_floats(text: str) -> list[float]:
    """``"0,0.1,0.2"`` → ``[0.0, 0.1, 0.2]`` (``ValueError`` on anything else)."""
    return [float(part) for part in text.split(",")]


class StrictRequest(BaseModel):
    """A number must be a JSON number (``"24.5"`` is refused); unknown fields are refused;
    ``null`` is the field's default."""

    model_config = ConfigDict(strict=True, extra="forbid")


def metadata_key_fields(*, checked_by_model: bool) -> dict[str, Any]:
    """The known metadata keys (``daq.store.run_metadata.KNOWN``, read now) as optional fields
    for ``create_model``, each with its help, its range or length and its option (``Flag``).

    ``checked_by_model``: the model checks the range and length (a query parameter or an
    option, whose error names it: ``water_temperature_c: '80' is not allowed; Input should
    be …``); else its JSON Schema only states them and the store's check gives the error
    (``metadata.water_temperature_c: 80 is not allowed; use -2 ≤ …``)."""
    fields: dict[str, Any] = {}
    for key in run_metadata.KNOWN:
        rule: dict[str, Any]
        if key.number_range is None:
            kind: Any = str
            rule = {"min_length": 1, "max_length": key.max_chars}
        else:
            kind = float
            low, high = key.number_range
            rule = {"ge": low, "le": high, "allow_inf_nan": False}
        option = Flag(key.option, metavar=key.metavar)
        # the label and unit a form shows it with (the pages build their inputs from these)
        shown: dict[str, Any] = {"title": key.title, "description": key.description}
        if key.unit:
            shown["json_schema_extra"] = {"unit": key.unit}
        if checked_by_model:  # on the field, where the options read it (a click range)
            field = _annotated(kind | None, Field(**shown, **rule), option)
        else:  # said in the schema ("maxLength", "minimum", …) only
            words = {_SCHEMA[k]: v for k, v in rule.items() if k in _SCHEMA}
            said = _annotated(kind, Field(json_schema_extra=words))
            field = _annotated(said | None, Field(**shown), option)
        fields[key.name] = (field, None)
    return fields


def _annotated(kind: Any, *marks: Any) -> Any:
    """``Annotated[kind, *marks]`` made at run time (a type checker reads only written ones)."""
    return Annotated[(kind, *marks)]


_Model = TypeVar("_Model", bound=BaseModel)

#: A field's rule as JSON Schema words.
_SCHEMA = {"ge": "minimum", "le": "maximum", "min_length": "minLength", "max_length": "maxLength"}


class _RunMetadataObject(BaseModel):
    """Free metadata of a run, the ``metadata`` object of a procedure request and the body
    of ``PATCH .../metadata`` (checked by ``daq.store.run_metadata``): the keys below and
    any other lower-case key with a text, number or true/false value. In a PATCH a ``null``
    removes the key."""

    model_config = ConfigDict(extra="allow")


def known_keys_model(
    name: str, base: type[_Model], *, checked_by_model: bool, **more: Any
) -> type[_Model]:
    """The model ``name`` on ``base`` (its methods and doc) with the known keys' fields as
    declared now (``metadata_key_fields``) and ``more`` (``create_model``'s
    ``(annotation, default)`` per field): both metadata models are made by it."""
    return create_model(
        name,
        __base__=base,
        __module__=base.__module__,
        __doc__=base.__doc__,
        **metadata_key_fields(checked_by_model=checked_by_model),
        **more,
    )


def run_metadata_model() -> type[_RunMetadataObject]:
    """The model of the ``metadata`` object, made from the known keys as declared now."""
    return known_keys_model(
        "RunMetadataIn",
        _RunMetadataObject,
        checked_by_model=False,
        tags=(
            list[str] | None,
            Field(
                None,
                max_length=MAX_TAGS,
                title="Tags",
                description="Tags to find the run by, e.g. ['fins-v2'].",
            ),
        ),
    )


if TYPE_CHECKING:  # the type checker sees the base; the fields are made from the table
    RunMetadataIn = _RunMetadataObject
else:
    RunMetadataIn = run_metadata_model()


def rig_of(info: ValidationInfo) -> RigConfig | None:
    """The rig file in the validation context (``None``: check the types only)."""
    return (info.context or {}).get("rig")


class ProcedureRequest(StrictRequest):
    """What every procedure start takes besides its own parameters (the CLI gives it with
    ``--operator``, ``--tag``, … from ``api.cli.metadata``, not from this field).

    Checked against a rig (:meth:`checked`) it is frozen and is the procedure's parameters."""

    #: Defaults are validated too: the rig fills in those it decides (``None``).
    model_config = ConfigDict(strict=True, extra="forbid", frozen=True, validate_default=True)
    #: The run kind these parameters run.
    kind: ClassVar[RunKind]
    #: The field holding the load that drives the run (``force_n``); ``None``: not driven.
    load_field: ClassVar[str | None] = None

    metadata: RunMetadataIn | None = Field(
        None, description="Stored on every run the procedure records (see PATCH .../metadata)."
    )

    def parameters(self) -> dict[str, Any]:
        """The procedure's own parameters, as given (unset ones left out)."""
        return self.model_dump(exclude_none=True, exclude={"metadata"})

    def run_metadata(self) -> dict[str, Any] | None:
        """The ``metadata`` object as given (None when absent)."""
        return None if self.metadata is None else self.metadata.model_dump(exclude_unset=True)

    @classmethod
    def checked(cls, raw: dict[str, Any], rig: RigConfig) -> Self:
        """``raw`` checked against ``rig`` → the frozen parameters; ``ParameterError``
        naming every bad field and its allowed range."""
        try:
            return cls.model_validate(raw, context={"rig": rig})
        except ValidationError as err:
            raise ParameterError(p.problems_of(err)) from None

    @classmethod
    def rig_limit(cls, name: str, rig: RigConfig) -> float | None:
        """The limit ``rig`` sets on field ``name`` (its :class:`RigLimit`); ``None``: none."""
        mark = _rig_limit_of(cls, name)
        return None if mark is None else mark.highest(rig)

    @classmethod
    def limit_named(cls, name: str) -> str:
        """``", rig limit max_force_n"``: the rig file's setting bounding field ``name``, as
        a refusal names it (its :class:`RigLimit`'s ``setting``); "" when it has none."""
        mark = _rig_limit_of(cls, name)
        return f", rig limit {mark.setting}" if mark is not None and mark.setting else ""

    @classmethod
    def field_limits(cls, rig: RigConfig) -> dict[str, dict[str, float]]:
        """``{field: {"max": …, "min"?: …}}`` for every field ``rig`` bounds (``GET /api/rig``
        → ``field_limits``; ``min`` = −max where the field is signed)."""
        out: dict[str, dict[str, float]] = {}
        for name in cls.model_fields:
            mark = _rig_limit_of(cls, name)
            high = None if mark is None else mark.highest(rig)
            if mark is None or high is None or not math.isfinite(high):
                continue
            out[name] = {"max": float(high)} | ({"min": -float(high)} if mark.signed else {})
        return out

    @classmethod
    def drive_limit(cls, rig: RigConfig) -> float | None:
        """The rig's limit on the driving load (``max_force_n``, ``max_torque_nm``);
        ``None``: not driven, or the rig file sets none."""
        return None if cls.load_field is None else cls.rig_limit(cls.load_field, rig)

    def to_json(self) -> dict[str, Any]:
        """The parameters as a run stores them (with its ``kind``)."""
        return self.model_dump(exclude={"metadata"}) | {"kind": self.kind}

    @field_validator("baseline_s", check_fields=False)
    @classmethod
    def _baseline(cls, value: float, info: ValidationInfo) -> float:
        if rig_of(info) is None:
            return value
        return p.in_range("baseline_s", value, low=0, high=30, unit="s", low_inclusive=True)

    @field_validator("max_time_s", check_fields=False)
    @classmethod
    def _max_time(cls, value: float | None, info: ValidationInfo) -> float | None:
        rig = rig_of(info)
        return value if rig is None else p.max_time(value, rig)


def _rig_limit_of(model: type[BaseModel], name: str) -> RigLimit | None:
    return next((m for m in model.model_fields[name].metadata if isinstance(m, RigLimit)), None)


Drive = Literal["weight", "thrusters"]
MaxTime = Annotated[
    float | None,
    Field(title="Max time (s)", description="Stop after this many seconds (default 120)."),
    Flag("--max-time"),
    RigLimit(lambda rig: rig.limits.max_run_s),
]
Baseline = Annotated[
    float, Field(title="Baseline (s)", description="Pre-trigger baseline, s."), Flag("--baseline")
]


class SignedLoadRequest(ProcedureRequest):
    """What a tow's and a spin's parameters share: a signed load (its sign is the test's
    direction) from a hung weight or from the thrusters, and the request it rounded.

    Checked against a rig, the load field holds the load applied (a hung weight's, to the
    gram), ``weight_kg`` is cleared and :attr:`hung_mass_kg` is the weight hung."""

    #: The load's field and unit (``force_n``, ``N``).
    load_field: ClassVar[str]
    load_unit: ClassVar[str]
    _hung_mass_kg: float | None = PrivateAttr(None)
    if TYPE_CHECKING:  # the subclasses' fields the checks read
        drive: str
        weight_kg: float | None
    _requested: dict[str, float] | None = PrivateAttr(None)

    @property
    def load(self) -> float:
        """The signed load: the tow's force (N) or the spin's torque (N·m)."""
        return float(getattr(self, self.load_field))

    @property
    def hung_mass_kg(self) -> float | None:
        """The weight hung (positive either way), kg; ``None`` when the thrusters drive."""
        return self._hung_mass_kg

    @property
    def requested(self) -> dict[str, float] | None:
        """What was asked for when the hung weight (to the gram) changed it."""
        return self._requested

    @property
    def reverse(self) -> bool:
        """A reverse test (negative load): a tow from the far end back toward the start, a
        spin with the cord wound the other way round the drum."""
        return self.load < 0

    def adjustment(self) -> str | None:
        """The sentence telling the operator the requested load was rounded, if it was."""
        return p.adjustment(self.requested, self.hung_mass_kg, f"{self.load:.5g} {self.load_unit}")

    def to_json(self) -> dict[str, Any]:
        data = super().to_json()
        del data["weight_kg"]
        return data | {"hung_mass_kg": self.hung_mass_kg, "requested": self.requested}

    @classmethod
    def _lever(cls, rig: RigConfig) -> tuple[float, float, str]:
        """The load one kg hung gives per g (1 m for a tow, the drum's radius for a spin),
        the load's limit and how it is named."""
        raise NotImplementedError

    @field_validator("*")
    @classmethod
    def _load(cls, value: Any, info: ValidationInfo) -> Any:
        """The load field (``load_field``) within the rig's limit on it, either sign."""
        rig = rig_of(info)
        if rig is None or info.field_name != cls.load_field:
            return value
        high, why = cls.drive_limit(rig) or math.nan, cls.limit_named(cls.load_field)
        return p.in_range(
            cls.load_field, value, low=0, high=high, unit=cls.load_unit, why_high=why, signed=True
        )

    @field_validator("weight_kg", check_fields=False)
    @classmethod
    def _weight(cls, value: float | None, info: ValidationInfo) -> float | None:
        rig = rig_of(info)
        if rig is None:
            return value
        radius, high, why = cls._lever(rig)
        per_kg = rig.rig.g * radius
        return p.in_range(
            "weight_kg", value, low=0, high=high / per_kg, unit="kg", why_high=why, signed=True
        )

    @model_validator(mode="wrap")
    @classmethod
    def _applied(
        cls, data: Any, handler: ModelWrapValidatorHandler[Self], info: ValidationInfo
    ) -> Self:
        rig = rig_of(info)
        if rig is None or not isinstance(data, dict):
            return handler(data)
        problems = p.load_given(data, cls.load_field, cls.load_unit, cls.kind)
        try:
            model = handler(data)
        except ValidationError as err:
            raise ParameterError(p.problems_of(err) + problems) from None
        if problems:
            raise ParameterError(problems)
        radius = cls._lever(rig)[0]
        given = getattr(model, cls.load_field)
        load, hung, requested = p.applied_load(
            model.drive, cls.load_field, given, model.weight_kg, rig.rig.g, radius
        )
        checked = model.model_copy(update={cls.load_field: load, "weight_kg": None})
        checked._hung_mass_kg, checked._requested = hung, requested
        return checked
