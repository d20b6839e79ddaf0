"""Click options derived from a request model (``daq.procedures.requests``), so a
procedure's parameters are declared once for the API and the CLI.

Each field with a :class:`~daq.procedures.requests.Flag` becomes one option: its name
from the flag, its type from the annotation, its default (shown) from the field's
default, a ``ge``/``gt``/``le``/``lt`` bound as a click range, and its help from the
field's description. An on/off flag (``--thrusters``) sets the field to ``when_set``.
"""

from __future__ import annotations

import enum
import types
import typing
from collections.abc import Callable
from typing import Annotated, Any, TypeVar

import annotated_types
import click
from pydantic import BaseModel
from pydantic.fields import FieldInfo

from api.cli.common import fail, flag_names
from daq.procedures.flag import Flag


def _flag(info: FieldInfo) -> Flag | None:
    return next((m for m in info.metadata if isinstance(m, Flag)), None)


def _base_type(annotation: Any) -> Any:
    """``float | None`` → ``float``."""
    if typing.get_origin(annotation) in (typing.Union, types.UnionType):
        args = [a for a in typing.get_args(annotation) if a is not type(None)]
        return args[0] if len(args) == 1 else annotation
    return annotation


class _Parsed(click.ParamType):
    """A value typed as text and parsed by the flag's ``parse`` (``0,0.2,0.4`` → a list)."""

    def __init__(self, parse: Callable[[str], Any], what: str) -> None:
        self.parse = parse
        self.name = what

    def convert(self, value: Any, param: click.Parameter | None, ctx: click.Context | None):
        if not isinstance(value, str):
            return value
        try:
            return self.parse(value)
        except ValueError:
            self.fail(f"got {value!r}; allowed: {self.name}", param, ctx)


def _click_type(info: FieldInfo, flag: Flag) -> Any:
    if flag.parse is not None:
        return _Parsed(flag.parse, f"the form {flag.metavar}" if flag.metavar else "a list")
    base = _base_type(info.annotation)
    if typing.get_origin(base) is typing.Literal:  # one of the listed words
        return click.Choice([str(word) for word in typing.get_args(base)])
    if isinstance(base, type) and issubclass(base, enum.Enum):  # one of its values
        return click.Choice([str(member.value) for member in base])
    bounds: dict[str, Any] = {}
    for m in info.metadata:
        if isinstance(m, annotated_types.Ge | annotated_types.Gt):
            bounds["min"] = m.ge if isinstance(m, annotated_types.Ge) else m.gt
            bounds["min_open"] = isinstance(m, annotated_types.Gt)
        elif isinstance(m, annotated_types.Le | annotated_types.Lt):
            bounds["max"] = m.le if isinstance(m, annotated_types.Le) else m.lt
            bounds["max_open"] = isinstance(m, annotated_types.Lt)
    if base is int:
        return click.IntRange(**bounds) if bounds else int
    if base is float:
        return click.FloatRange(**bounds) if bounds else float
    if base is bool:
        return bool
    return str


#: A click command, or the function a command is being built from.
F = TypeVar("F", bound=Callable[..., Any])
#: A request model.
M = TypeVar("M", bound=BaseModel)


def _element(annotation: Any) -> Any:
    """``list[str]`` → ``str`` (``list[Annotated[float, …]]`` → ``float``: its range is the
    model's to check); ``None`` for anything but a list."""
    base = _base_type(annotation)
    if typing.get_origin(base) is not list:
        return None
    element = typing.get_args(base)[0]
    return typing.get_args(element)[0] if typing.get_origin(element) is Annotated else element


def _repeatable(help_text: str) -> str:
    """The help of a repeatable option: its text, then "Repeatable."."""
    text = help_text.rstrip()
    return f"{text}{' ' if text.endswith('.') else '. ' if text else ''}Repeatable."


class ModelOption(click.Option):
    """An option made from a field of a request model (the docs list a command's own
    options, ``cli:`` in ``api.cli.docs_tables``'s spans, apart from its models')."""


def model_options(model: type[BaseModel], *, required: bool = True) -> list[click.Option]:
    """One click option per flagged field of ``model`` (in field order): a list field is a
    repeatable option. ``required=False``: no option is required on the command line (a
    command offering two requests checks the one the user chose)."""
    options: list[click.Option] = []
    for name, info in model.model_fields.items():
        flag = _flag(info)
        if flag is None:
            continue
        if flag.when_set is not None:
            option = ModelOption(
                [flag.name, name], is_flag=True, help=flag.help or info.description
            )
        elif flag.parse is None and (element := _element(info.annotation)) is not None:
            if typing.get_origin(element) is typing.Literal:  # one of the listed words
                element = click.Choice([str(word) for word in typing.get_args(element)])
            option = ModelOption(
                [flag.name, name],
                type=element,
                multiple=True,
                required=required and info.is_required(),
                metavar=flag.metavar,
                help=_repeatable(flag.help or info.description or ""),
            )
        else:
            # a required field has no default at all (click ≥ 8.3 takes None as one)
            default = {} if info.is_required() else {"default": info.default}
            option = ModelOption(
                [flag.name, name],
                type=_click_type(info, flag),
                required=required and info.is_required(),
                show_default=default.get("default") not in (None, ""),  # "" says nothing
                metavar=flag.metavar,
                help=flag.help or info.description,
                **default,
            )
        options.append(option)
    return options


def request_options(model: type[BaseModel], *, required: bool = True) -> Callable[[F], F]:
    """A decorator adding :func:`model_options` to a command (or the function a command is
    being built from), before the options declared below it."""

    def decorate(command: F) -> F:
        options = model_options(model, required=required)
        if isinstance(command, click.Command):
            command.params.extend(options)
        else:  # click.option's way: the command is built from this list, reversed
            params = command.__dict__.setdefault("__click_params__", [])
            params.extend(reversed(options))
        return command

    return decorate


def request_fields(model: type[BaseModel], values: dict[str, Any]) -> dict[str, Any]:
    """The request (as a dict of the fields given) from the options' ``values``."""
    given: dict[str, Any] = {}
    for name, info in model.model_fields.items():
        flag = _flag(info)
        if flag is None or name not in values:
            continue
        value = values[name]
        if flag.when_set is not None:
            if value:
                given[name] = flag.when_set
        elif isinstance(value, tuple):  # a repeatable option: given when repeated at least once
            if value:
                given[name] = list(value)
        elif value is not None:
            given[name] = value
    return given


def _defaults_need_no_check(model: type[BaseModel]) -> bool:
    """Whether validating no input would only take the field defaults: no field is required
    or validates its default, and no model validator runs. Then a deferred model
    (``defer_build``, e.g. the list filters: ~0.06 s of CPU to build) is not built for a
    command given none of its options."""
    decorators = model.__pydantic_decorators__
    if decorators.model_validators or decorators.root_validators:
        return False
    every = bool(model.model_config.get("validate_default"))
    return not any(
        info.is_required() or info.validate_default or (every and info.validate_default is None)
        for info in model.model_fields.values()
    )


def _is_default(info: FieldInfo, value: Any) -> bool:
    """Whether ``value`` is the field's default itself (same type and value): validating it
    gives the default, as no input does."""
    return type(value) is type(info.default) and value == info.default


def request_from(model: type[M], values: dict[str, Any], **given: Any) -> M:
    """The request ``model`` from the options' ``values`` plus ``given`` fields (an argument),
    exactly as its route takes it; a bad value exits 2 with one line per field, each named as
    the command line spells it (``--temp: …``)."""
    from pydantic import ValidationError

    from daq.procedures.params import ParameterError, problems_of  # only to word a refusal

    fields = request_fields(model, values)
    if (
        not given
        and _defaults_need_no_check(model)
        and all(_is_default(model.model_fields[name], value) for name, value in fields.items())
    ):  # an option left at its default (``rig runs``' --limit 100) is no input
        return model.model_construct()  # what validating no input gives, without building it
    try:
        return model(**given, **fields)
    except ValidationError as err:
        ctx = click.get_current_context(silent=True)
        fail(flag_names(ctx, str(ParameterError(problems_of(err)))))
        raise  # not reached: fail exits
