"""Command-line options generated from a dataclass: each setting is declared once, as a field.

A field marked with ``option(...)`` becomes an argparse option (CleanRL's dataclass-of-arguments style):
its flag is the field's name (``num_envs``: ``--num-envs``) unless ``flag`` names another, its type follows
the annotation (``bool``: ``--x/--no-x``, or ``--x`` alone for a switch that is off by default; ``list[T]``:
several values, or with ``repeat`` the option given again), and its help is the first sentence of the
docstring under the field, which says what the setting is for.
"""

from __future__ import annotations

import argparse
import ast
import dataclasses
import inspect
import json
import re
import textwrap
import types
import typing
from collections.abc import Callable, Iterable


def option(
    default=dataclasses.MISSING,
    *,
    default_factory=dataclasses.MISSING,
    flag: str | None = None,
    metavar: str | None = None,
    choices: Iterable | None = None,
    repeat: bool = False,
    parse: Callable[[str], object] | None = None,
    required: bool = False,
):
    """A dataclass field that is also a command-line option (see the module docstring); ``parse`` turns the
    text of one value into the field's (default: the annotation's type)."""
    spec = {"flag": flag, "metavar": metavar, "choices": choices, "repeat": repeat, "parse": parse}
    spec["required"] = required
    return dataclasses.field(default=default, default_factory=default_factory, metadata={"option": spec})


def option_fields(cls) -> list[dataclasses.Field]:
    """The fields of the dataclass ``cls`` that are options."""
    return [field for field in dataclasses.fields(cls) if "option" in field.metadata]


def flag(field: dataclasses.Field) -> str:
    """The option's flag, e.g. ``--num-envs``."""
    return field.metadata["option"]["flag"] or "--" + field.name.replace("_", "-")


def add_options(parser, cls, names: Iterable[str] | None = None, *, unset: bool = True) -> None:
    """Add to ``parser`` (or an argument group) the options of ``cls``'s fields (only ``names``, when given).

    With ``unset`` an option not given is None, so that the caller can tell it from a value given (a
    config's own default, or a saved one, then applies); otherwise it is the field's default.
    """
    hints = typing.get_type_hints(cls)
    docs = field_docs(cls)
    wanted = None if names is None else set(names)
    for field in option_fields(cls):
        if wanted is not None and field.name not in wanted:
            continue
        spec = field.metadata["option"]
        default = None if unset else _default(field)
        arguments = _arguments(_without_none(hints[field.name]), spec, default)
        if spec["required"]:
            arguments["required"] = True
        for key in ("metavar", "choices"):
            if spec[key] is not None:
                arguments[key] = tuple(spec[key]) if key == "choices" else spec[key]
        parser.add_argument(flag(field), dest=field.name, help=help_line(docs[field.name]), **arguments)


def _arguments(kind, spec: dict, default) -> dict:
    """argparse's keywords for an option of type ``kind``."""
    if kind is bool:
        if default is False:  # a switch
            return {"action": "store_true"}
        return {"action": argparse.BooleanOptionalAction, "default": default}
    if typing.get_origin(kind) is list:
        (item,) = typing.get_args(kind)
        parse = spec["parse"] or item
        return {
            "type": parse,
            "default": default,
            **({"action": "append"} if spec["repeat"] else {"nargs": "+"}),
        }
    return {"type": spec["parse"] or (json_object if kind is dict else kind), "default": default}


def _without_none(kind):
    """``T`` of ``T | None``."""
    if typing.get_origin(kind) in (typing.Union, types.UnionType):
        (kind,) = [member for member in typing.get_args(kind) if member is not type(None)]
    return kind


def _default(field: dataclasses.Field):
    if field.default_factory is not dataclasses.MISSING:
        return field.default_factory()
    return None if field.default is dataclasses.MISSING else field.default


def field_docs(cls) -> dict[str, str]:
    """The docstring under each field of the dataclass ``cls`` (a subclass's over its bases')."""
    docs = {}
    for klass in reversed(cls.__mro__):
        if not dataclasses.is_dataclass(klass):
            continue
        body = ast.parse(textwrap.dedent(inspect.getsource(klass))).body[0].body
        for node, after in zip(body, body[1:]):
            if (
                isinstance(node, ast.AnnAssign)
                and isinstance(node.target, ast.Name)
                and isinstance(after, ast.Expr)
                and isinstance(after.value, ast.Constant)
                and isinstance(after.value.value, str)
            ):
                docs[node.target.id] = after.value.value
    return docs


def help_line(doc: str) -> str:
    """The first sentence of a field's docstring, on one line, without reST's double backquotes (and with
    argparse's ``%`` escaped)."""
    text = " ".join(doc.replace("``", "").split())
    return re.split(r"(?<=\.)\s", text, maxsplit=1)[0].removesuffix(".").replace("%", "%%")


def json_object(text: str) -> dict:
    """argparse type: a JSON object."""
    try:
        value = json.loads(text)
    except json.JSONDecodeError as error:
        raise argparse.ArgumentTypeError(f"not valid JSON ({error})") from None
    if not isinstance(value, dict):
        raise argparse.ArgumentTypeError(f"{text!r} is not a JSON object: write '{{\"name\": value, ...}}'")
    return value
