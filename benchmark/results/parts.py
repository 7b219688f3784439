"""The machinery of the result file's typed parts: a frozen dataclass per JSON object.

A part declares each JSON field as a dataclass field made by :func:`item`, with the
check that validates (and, for nested parts, builds) its value. :meth:`Part.from_json`
checks an object field by field and raises one :class:`Located` error naming the
field's path, what was expected and what arrived (``benchmark.results.check`` adds
the file and raises it as a :class:`~blendvoca.errors.DataError`);
:meth:`Part.to_json` gives the object back as it was read: fields the part does not
know, and known fields written as ``null``, are kept in :attr:`Part.extra`, so a file
read and written again is the same file.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from dataclasses import dataclass, field

__all__ = ["Invalid", "Located", "Part", "anything", "integer", "integers", "item", "kind", "list_of", "located",
           "mapping_of", "number", "numbers", "obj", "optional", "pair", "part", "seconds", "short", "string",
           "to_json", "truth"]


class Invalid(ValueError):
    """A field's value is not what the schema expects: ``(expected, value)``, or
    ``(message,)``; :func:`located` adds the field's path."""


def short(value) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def item(check, *, key: str | None = None, required: bool = False, present: bool = False, always: bool = False):
    """A part's field: ``check(value, where)`` returns the typed value or raises
    :class:`Invalid`; ``key``: the JSON name when it is not the attribute's;
    ``required``: absent or null is refused; ``present``: absent is refused (null is
    not); ``always``: written as ``null`` when None."""
    return field(default=None, metadata={"check": check, "key": key, "required": required, "present": present,
                                         "always": always})


def _is_number(value) -> bool:
    try:  # OverflowError: an integer too large for a float
        return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)
    except OverflowError:
        return False


def kind(expected: str, test, convert=None):
    """A check of a plain value: ``test(value)`` true, else :class:`Invalid` saying ``expected``;
    the value is returned as read (``convert(value)`` when given)."""
    def check(value, where):
        if not test(value):
            raise Invalid(expected, value)
        return value if convert is None else convert(value)
    return check


def _is_int(value) -> bool:
    return isinstance(value, int) and not isinstance(value, bool)


number = kind("a finite number", _is_number)
seconds = kind("seconds >= 0 or null", lambda v: _is_number(v) and v >= 0)
integer = kind("an integer", _is_int)
string = kind("a string", lambda v: isinstance(v, str))
truth = kind("true or false", lambda v: isinstance(v, bool))
#: A JSON object, kept as written.
obj = kind("an object", lambda v: isinstance(v, dict))
#: Any JSON value, kept as written.
anything = kind("anything", lambda v: True)
#: Bootstrap replicates.
numbers = kind("a non-empty list of finite numbers",
               lambda v: isinstance(v, list) and bool(v) and all(_is_number(x) for x in v))
#: An interval: ``[low, high]``, low <= high.
pair = kind("[low, high] of finite numbers",
            lambda v: isinstance(v, list) and len(v) == 2 and all(_is_number(x) for x in v) and v[0] <= v[1])
integers = kind("a list of integers", lambda v: isinstance(v, list) and all(_is_int(x) for x in v), tuple)


def optional(check):
    """``check``, or None for null."""
    return lambda value, where: None if value is None else check(value, where)


def part(cls):
    """A nested part: the value is checked and built by ``cls.from_json``."""
    return lambda value, where: cls.from_json(value, where)


def list_of(check, expected: str = "a list"):
    """A list whose items pass ``check`` (``where[i]``), as a tuple."""
    def checked(value, where):
        if not isinstance(value, list):
            raise Invalid(expected, value)
        return tuple(located(check, v, f"{where}[{i}]") for i, v in enumerate(value))
    return checked


def mapping_of(check, expected: str = "an object"):
    """An object whose values pass ``check`` (``where.name``)."""
    def checked(value, where):
        if not isinstance(value, dict):
            raise Invalid(expected, value)
        return {str(k): located(check, v, f"{where}.{k}") for k, v in value.items()}
    return checked


class Located(ValueError):
    """An :class:`Invalid` value with the path of its field (``where: message``)."""


def located(check, value, where: str):
    """``check(value, where)``, its :class:`Invalid` raised as :class:`Located` at ``where``."""
    try:
        return check(value, where)
    except Invalid as exc:
        message = exc.args[0] if len(exc.args) == 1 else f"expected {exc.args[0]}, got {short(exc.args[1])}"
        raise Located(f"{where}: {message}") from None


@dataclass(frozen=True, kw_only=True)
class Part:
    """A typed JSON object of the result file (see the module docstring).

    Attributes
    ----------
    extra : dict
        Fields this version does not type (kept as written, so they survive a read and
        a write), and typed fields written as ``null``.
    """

    extra: dict = field(default_factory=dict, repr=False)
    #: Whether fields the part does not declare are kept (True) or refused (False).
    OPEN = True

    @classmethod
    def from_json(cls, value, where: str):
        """The part of a parsed JSON object ``value`` at ``where`` (a field path).

        Raises
        ------
        Located
            Naming the field and what was expected (:func:`benchmark.results.check`
            adds the file).
        """
        if not isinstance(value, dict):
            raise Located(f"{where}: expected an object, got {short(value)}")
        fields, values, extra = _json_fields(cls), {}, {}
        for f, key in fields:
            present = value.get(key)
            if (f.metadata["present"] and key not in value) or (present is None and f.metadata["required"]):
                raise Located(f"{where}: lacks {key!r} (got fields {sorted(value)})")
            if present is not None:
                values[f.name] = located(f.metadata["check"], present, f"{where}.{key}")
            elif key in value and not f.metadata["always"]:
                extra[key] = None
        known = {key for _, key in fields}
        unknown = {k: v for k, v in value.items() if k not in known}
        if unknown and not cls.OPEN:
            raise Located(f"{where}.{sorted(unknown)[0]}: unknown field; expected some of {tuple(sorted(known))}")
        built = cls(**values, extra={**unknown, **extra})
        located(built.validate, None, where)
        return built

    def validate(self, value, where: str) -> None:
        """Checks across fields (a part that needs them overrides this and raises
        :class:`Invalid`); ``value`` is unused (the :func:`located` signature)."""

    def to_json(self) -> dict:
        """The JSON object of this part (what :meth:`from_json` read)."""
        out = dict(self.extra)
        for f, key in _json_fields(type(self)):
            value = getattr(self, f.name)
            if value is not None or f.metadata["always"]:
                out[key] = to_json(value)
        return out


def _json_fields(cls) -> list:
    """``[(field, JSON key)]`` of a part's declared fields."""
    return [(f, f.metadata["key"] or f.name) for f in dataclasses.fields(cls) if f.name != "extra"]


def to_json(value):
    """Parts, tuples and mappings of them as plain JSON values."""
    if isinstance(value, Part):
        return value.to_json()
    if isinstance(value, Mapping):
        return {k: to_json(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [to_json(v) for v in value]
    return value
