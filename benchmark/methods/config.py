"""Typed config declarations of method plug-ins (docs/methods.md, "Config options").

A method declares the keys its constructor accepts as a :class:`ConfigSchema` of
:class:`Option` (name, type, default, help, choices). ``benchmark.run --config
KEY=VALUE`` values are read against it before any corpus or training work: an
unknown key or a value of the wrong type is a :class:`~blendvoca.errors.UserError`
(one ``error:`` line, exit 2) naming the key, the expected type and what arrived.

:meth:`Method.config_schema <benchmark.methods.base.Method.config_schema>` derives a
schema from the plug-in's ``__init__`` signature (annotations, defaults and the
numpydoc ``Parameters`` of the class docstring); preset-based methods add the keys of
their presets with :meth:`ConfigSchema.with_presets`. A plug-in whose constructor only
takes ``**config`` declares nothing: its values are only parsed as JSON.
"""

from __future__ import annotations

import difflib
import inspect
import json
import os
import re
import types
import typing
from dataclasses import dataclass, field

from blendvoca.errors import UserError

__all__ = ["ConfigSchema", "Option", "parse_value", "preset_keys", "type_name"]

#: Types an option may declare; ``object`` accepts any JSON value.
_TYPE_NAMES = {bool: "bool", int: "int", float: "float", str: "str", list: "list", dict: "dict",
               type(None): "null", object: "any"}
_BY_NAME = {name: tp for tp, name in _TYPE_NAMES.items()}
_BY_NAME.update({"None": type(None), "tuple": list, "Any": object, "Path": str, "os.PathLike": str,
                 "PathLike": str})


def preset_keys(preset: dict, prefixes: dict | None = None) -> dict[str, tuple[str | None, str]]:
    """Where each flat config key of a preset lands: the one rule of preset overrides.

    A preset (``baselines/*/presets.py``) is ``{section: {key: value}}`` beside
    top-level values (``wav2vec2_path``). A section's key is set by its flat name, with
    the section's prefix from ``prefixes`` (CodeTalker's ``{"stage1": "vq_"}``); a
    top-level value by its own name.

    Returns
    -------
    dict
        ``{flat_key: (section, key)}``, ``section`` None for a top-level value.
    """
    prefixes = prefixes or {}
    keys: dict[str, tuple[str | None, str]] = {}
    for section, values in preset.items():
        if isinstance(values, dict):
            keys.update({prefixes.get(section, "") + key: (section, key) for key in values})
        else:
            keys[section] = (None, section)
    return keys


def type_name(types_: tuple) -> str:
    """``(float, NoneType)`` -> ``"float | null"``."""
    return " | ".join(_TYPE_NAMES.get(tp, getattr(tp, "__name__", str(tp))) for tp in types_)


def _value_type(value) -> str:
    """The JSON kind of a value as read from the command line, for error messages."""
    if value is None:
        return "null"
    return _TYPE_NAMES.get(type(value), type(value).__name__)


def _matches(value, tp) -> bool:
    if tp is object:
        return True
    if tp is type(None):
        return value is None
    if tp is bool:
        return isinstance(value, bool)
    if tp is int:
        return isinstance(value, int) and not isinstance(value, bool)
    if tp is float:  # an integer literal is a fine float (lr=1)
        return isinstance(value, (int, float)) and not isinstance(value, bool)
    if tp is list:
        return isinstance(value, (list, tuple))
    return isinstance(value, tp)


def _is_number(value) -> bool:
    """True for an int or float that is not a bool."""
    return isinstance(value, (int, float)) and not isinstance(value, bool)


@dataclass(frozen=True)
class Option:
    """One config key of a method.

    Parameters
    ----------
    name : str
        The key (``--config NAME=VALUE``).
    types : tuple of type
        Accepted types among ``bool, int, float, str, list, dict, NoneType`` and
        ``object`` (any JSON value); an ``int`` is accepted where ``float`` is.
    default : object
        The value the method uses when the key is not given.
    help : str
        One line for ``--list-config`` and docs.
    choices : tuple or None
        The only values accepted, when the set is closed.
    minimum : number or None
        The smallest number accepted (None, and the option's null, are not numbers).
    below : str or None
        The name of an option this one's number must be smaller than, when both are given
        (``chunk_overlap`` below ``chunk_frames``).
    """

    name: str
    types: tuple = (object,)
    default: object = None
    help: str = ""
    choices: tuple | None = None
    minimum: float | None = None
    below: str | None = None

    @property
    def type(self) -> str:
        """The declared type as text, e.g. ``"int | null"``."""
        return type_name(self.types)

    def check(self, value, *, method: str = "method"):
        """``value`` if it fits the declaration, else a :class:`UserError` naming the key."""
        if not any(_matches(value, tp) for tp in self.types):
            raise UserError(f"--config {self.name}: {method} expects {self.type}, got {json.dumps(value)} "
                            f"({_value_type(value)})")
        if self.choices is not None and value not in self.choices:
            raise UserError(f"--config {self.name}: {method} expects one of "
                            f"{', '.join(json.dumps(c) for c in self.choices)}, got {json.dumps(value)}")
        if self.minimum is not None and _is_number(value) and value < self.minimum:
            raise UserError(f"--config {self.name}: {method} expects a number >= {self.minimum:g}, "
                            f"got {json.dumps(value)}")
        return value

    def describe(self) -> str:
        """``name (type, default X; one of ...): help`` for ``--list-config``."""
        extra = f"default {json.dumps(self.default)}"
        if self.choices is not None:
            extra += "; one of " + ", ".join(json.dumps(c) for c in self.choices)
        if self.minimum is not None:
            extra += f"; at least {self.minimum:g}"
        if self.below is not None:
            extra += f"; below {self.below}"
        return f"{self.name} ({self.type}, {extra})" + (f": {self.help}" if self.help else "")


def parse_value(text: str, option: Option | None = None):
    """A ``--config`` value from its text: JSON when it parses, else the text itself.

    Where ``option`` accepts ``str`` and not the JSON type the text would parse to
    (``style=1``, ``name=null``), the text is kept as a string, so that a declared
    string option never needs JSON quotes.
    """
    try:
        value = json.loads(text)
    except ValueError:
        return text
    if option is not None and str in option.types and not any(_matches(value, tp) for tp in option.types):
        return text
    return value


@dataclass(frozen=True)
class ConfigSchema:
    """The config keys a method accepts.

    Parameters
    ----------
    options : dict of str to Option
        The declared keys, in declaration order.
    open : bool
        True when the constructor takes further keys it does not declare (``**kwargs``
        not covered by presets): unknown keys are then passed on unchecked.
    """

    options: dict = field(default_factory=dict)
    open: bool = False

    def __iter__(self):
        return iter(self.options.values())

    def __contains__(self, name) -> bool:
        return name in self.options

    def __getitem__(self, name) -> Option:
        return self.options[name]

    def check(self, config: dict, *, method: str = "method") -> dict:
        """``config`` checked against the declaration (keys and types), unchanged.

        Raises
        ------
        UserError
            An unknown key (with the close matches) or a value of the wrong type.
        """
        for key, value in config.items():
            if key in self.options:
                self.options[key].check(value, method=method)
            elif not self.open:
                close = difflib.get_close_matches(key, self.options, n=3)
                hint = f" (did you mean {', '.join(close)}?)" if close else \
                    f"; `--list-config` lists its {len(self.options)} keys"
                raise UserError(f"--config {key}: {method} has no such option{hint}")
        for key, value in config.items():
            option = self.options.get(key)
            bound = config.get(option.below) if option is not None and option.below else None
            if _is_number(value) and _is_number(bound) and value >= bound:
                raise UserError(f"--config {key}: {method} expects a number below {option.below} ({bound}), "
                                f"got {json.dumps(value)}")
        return config

    def parse(self, pairs, *, method: str = "method") -> dict:
        """``KEY=VALUE`` strings read with :func:`parse_value` against the declaration, then checked."""
        config = {}
        for pair in pairs:
            key, sep, text = str(pair).partition("=")
            if not sep or not key:
                raise UserError(f"--config: expected KEY=VALUE, got {pair!r}")
            config[key] = parse_value(text, self.options.get(key))
        return self.check(config, method=method)

    def describe(self) -> str:
        """One line per option (``--list-config``)."""
        lines = [option.describe() for option in self]
        if self.open:
            lines.append("(further keys are passed to the method unchecked)")
        return "\n".join(lines)

    def with_options(self, *options: Option, open: bool | None = None) -> ConfigSchema:
        """This schema with ``options`` added (or replacing those of the same name)."""
        merged = dict(self.options)
        merged.update({option.name: option for option in options})
        return ConfigSchema(merged, self.open if open is None else open)

    def with_presets(self, presets: dict, *, default: str, extra: tuple = (),
                     prefixes: dict | None = None, help: dict | None = None) -> ConfigSchema:
        """This schema plus the flat keys of ``presets`` (``{name: {section: {key: value}}}``,
        the layout of ``baselines/*/presets.py``), closed to other keys.

        Each key's type is the union of its values' types over the presets (an integer
        and a float give float, a None makes it nullable); its default is the
        ``default`` preset's value; ``preset`` gets the preset names as choices.
        ``extra`` adds options the presets' resolver accepts besides their keys
        (e.g. ``wav2vec2_path``); ``prefixes`` maps a section to the prefix its flat
        keys take (CodeTalker's ``{"stage1": "vq_"}``); ``help`` gives a flat key its own
        sentence (``{"lr": "Adam learning rate"}``), followed by its section and the
        presets' values (a key without one gets those alone).
        """
        found: dict[str, dict] = {}
        for name, sections in presets.items():
            for key, (section, inner) in preset_keys(sections, prefixes).items():
                slot = found.setdefault(key, {"section": section, "values": {}})
                slot["values"][name] = sections[section][inner] if section is not None else sections[inner]
        options = []
        for key, slot in found.items():
            if key in self.options:
                continue
            kinds = [list if isinstance(value, tuple) else type(value) for value in slot["values"].values()]
            kinds = list(dict.fromkeys(kind if kind in _TYPE_NAMES else object for kind in kinds))
            if int in kinds and float in kinds:
                kinds.remove(int)
            if kinds == [type(None)]:  # never set in any preset: no type to read
                kinds = [object]
            if dict in kinds:  # nested specs (an encoder) may also be named by a kind string
                kinds.append(str)
            kinds.sort(key=lambda tp: tp is type(None))
            where = f"{slot['section']} section" if slot["section"] else "top level"
            values = ", ".join(f"{p}: {json.dumps(v)}" for p, v in slot["values"].items())
            own = (help or {}).get(key)
            text = f"{own} (preset {where}: {values})" if own else f"preset {where} ({values})"
            options.append(Option(key, tuple(kinds), slot["values"].get(default), text))
        schema = self.with_options(*options, *extra, open=False)
        if "preset" in schema:
            preset = schema["preset"]
            schema = schema.with_options(Option("preset", (str,), default, preset.help or "named preset",
                                                tuple(presets)))
        return schema

    @classmethod
    def from_signature(cls, function, doc: str | None = None, *, skip=("self",)) -> ConfigSchema | None:
        """The schema of ``function``'s keyword parameters (a plug-in's ``__init__``).

        Types come from the annotations (``int``, ``float | None``, ``str``, ...; an
        annotation it cannot read accepts any JSON value), defaults from the
        signature, help lines from the numpydoc ``Parameters`` of ``doc``. ``**kwargs``
        makes the schema open. None when the function takes only ``**kwargs``
        (nothing is declared).
        """
        signature = inspect.signature(function)
        try:
            hints = typing.get_type_hints(function)
        except Exception:  # noqa: BLE001 - an annotation that does not evaluate: read its text
            hints = {}
        helps, choices = _parameter_help(doc or "")
        options, open_ = {}, False
        for name, param in signature.parameters.items():
            if name in skip or param.kind is param.VAR_POSITIONAL:
                continue
            if param.kind is param.VAR_KEYWORD:
                open_ = True
                continue
            annotation = hints.get(name, param.annotation)
            kinds = _annotation_types(annotation)
            default = None if param.default is param.empty else param.default
            if default is not None and not any(_matches(default, tp) for tp in kinds):
                kinds = (*kinds, list if isinstance(default, tuple) else type(default))
            options[name] = Option(name, kinds, list(default) if isinstance(default, tuple) else default,
                                   helps.get(name, ""), choices.get(name))
        if not options and open_:
            return None
        return cls(options, open_)


def _union(kinds) -> tuple:
    """The distinct ``kinds`` in order; ``(object,)`` when one of them accepts anything."""
    kinds = tuple(dict.fromkeys(kinds))
    return kinds if object not in kinds else (object,)


def _annotation_types(annotation) -> tuple:
    """Python types accepted for an annotation (an object or its text)."""
    if annotation is inspect.Parameter.empty:
        return (object,)
    if isinstance(annotation, str):
        parts = annotation.replace("Optional[", "").rstrip("]").split("|")
        return _union(_BY_NAME.get(part.strip().split("[")[0], object) for part in parts)
    origin = typing.get_origin(annotation)
    if origin in (typing.Union, types.UnionType):
        return _union(kind for arg in typing.get_args(annotation) for kind in _annotation_types(arg))
    if origin is typing.Literal:
        return tuple(dict.fromkeys(type(arg) for arg in typing.get_args(annotation)))
    if origin in (list, tuple):
        return (list,)
    if origin is dict:
        return (dict,)
    if annotation in _TYPE_NAMES:
        return (annotation,)
    if annotation is tuple:
        return (list,)
    if annotation is os.PathLike or isinstance(annotation, type) and issubclass(annotation, str):
        return (str,)
    return (object,)


def plain_text(text: str) -> str:
    """``text`` without reStructuredText markup, as a terminal shows it: ````x```` reads
    ``x``, ``:role:`x``` reads ``x`` (``:role:`~a.b``` reads ``b``)."""
    text = re.sub(r":[a-z]+(?::[a-z]+)*:`~([^`]+)`", lambda m: m.group(1).rsplit(".", 1)[-1], text)
    text = re.sub(r":[a-z]+(?::[a-z]+)*:`([^`]+)`", r"\1", text)
    return re.sub(r"``([^`]+)``", r"\1", text)


def _parameter_help(doc: str) -> tuple[dict, dict]:
    """``{name: first sentence}`` and ``{name: choices}`` from a numpydoc ``Parameters``
    section (``a, b : int`` names both; a type ``{"x", "y"}`` gives the choices)."""
    doc = inspect.cleandoc(doc)
    match = re.search(r"^Parameters\n-+\n(.*?)(?:\n\n[A-Z][a-z]+\n-+\n|\Z)", doc, re.S | re.M)
    if not match:
        return {}, {}
    helps, choices, names, lines = {}, {}, [], []

    def flush():
        text = plain_text(" ".join(lines).strip())
        text = text.split(". ")[0].rstrip(".")
        for name in names:
            helps[name] = text

    for line in match.group(1).splitlines():
        if line and not line.startswith(" "):
            flush()
            names = [n.strip().lstrip("*") for n in line.split(":")[0].split(",")]
            lines = []
            spec = re.match(r"[^:]*:\s*\{([^}]*)\}", line)
            if spec:
                try:
                    values = tuple(json.loads(f"[{spec.group(1)}]"))
                except ValueError:  # not a JSON list of literals: no closed set to check
                    values = None
                for name in names:
                    choices[name] = values
        elif line.strip():
            lines.append(line.strip())
    flush()
    return helps, {name: values for name, values in choices.items() if values}

