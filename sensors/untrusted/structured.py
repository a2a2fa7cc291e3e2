"""TOML and JSON from outside, with nesting, dotted keys and item counts bounded before parsing.

The bounds are counted by a scan that drops strings and comments (so brackets, commas and dots inside
them do not count) and then counts what is left; it never recurses and its memory is a copy of the
text. Where the scan and the parser could disagree (text that is not valid TOML/JSON), the scan
counts more, never less, and the parser then refuses the text anyway.
"""

from __future__ import annotations

import json
import re
import tomllib
from itertools import accumulate
from typing import Any

from sensors.untrusted.errors import UntrustedInput, one_line
from sensors.untrusted.files import Pathish, decode_text, read_bytes
from sensors.untrusted.limits import CONFIG_TOML, JSON_SIDECAR, InputLimits

# Possessive quantifiers (*+, Python ≥ 3.11): no backtracking, so no memory that grows with a string.
_TOML_DROPPED = re.compile(
    r'"""(?:[^"\\]++|\\[\s\S]|"(?!""))*+"""(?:""|")?+'  # multi-line basic string (may end in 1–2 quotes)
    r"|'''(?:[^']++|'(?!''))*+'''(?:''|')?+"  # multi-line literal string
    r'|"(?:[^"\\\n]++|\\.)*+"'  # basic string
    r"|'[^'\n]*+'"  # literal string
    r"|#[^\n]*+"  # comment
)
_JSON_DROPPED = re.compile(r'"(?:[^"\\]++|\\[\s\S])*+"')
_TOML_SEPARATORS = re.compile(r"[=,\[\]{}\n]")
_STEP = {"[": 1, "{": 1, "]": -1, "}": -1}
_NOT_BRACKETS = re.compile(r"[^\[\]{}]++")


def toml_shape(text: str) -> tuple[int, int, int]:
    """(bracket nesting depth, most parts in one dotted key or table header, keys + array items) of
    TOML ``text``, counted without parsing it; each at least the parser's own count. The parsed value
    nests at most (depth + 2) × parts + depth deep (dotted keys in the header and at every level; with
    the default 16 and 16, 304: within Python's recursion limit for code walking the result)."""
    bare = _bare_toml(text)
    parts = 1 + max((len(seg) - len(seg.replace(".", "")) for seg in _TOML_SEPARATORS.split(bare)), default=0)
    items = sum(bare.count(c) for c in "=,[{")
    return _depth(bare), parts, items


def _bare_toml(text: str) -> str:
    """``text`` with each string and comment replaced by 's' and the newlines it held (lines kept)."""
    return _TOML_DROPPED.sub(lambda m: "s" + "\n" * m.group().count("\n"), text)


def json_shape(text: str) -> tuple[int, int]:
    """(nesting depth, keys + array items) of JSON ``text``, counted without parsing it."""
    bare = _JSON_DROPPED.sub("s", text)
    return _depth(bare), sum(bare.count(c) for c in ",[{:")


def parse_toml(text: str, source: Pathish, limits: InputLimits = CONFIG_TOML) -> dict[str, Any]:
    """TOML ``text`` (from ``source``, named in errors) as a dict, refused with one line if it is
    longer than ``limits.max_bytes`` characters, nests deeper than ``limits.max_depth``, has a key of
    more than ``limits.max_key_parts`` parts or more than ``limits.max_items`` keys and items, all
    checked before parsing; a syntax error becomes ``UntrustedInput`` naming the line."""
    if len(text) > limits.max_bytes:
        raise UntrustedInput(source, f"{len(text)} characters of TOML, more than the {limits.max_bytes} allowed")
    depth, parts, items = toml_shape(text)
    if depth > limits.max_depth or parts > limits.max_key_parts:
        bare = _bare_toml(text)
        if depth > limits.max_depth:
            line = _line_deeper_than(bare, limits.max_depth)
            raise UntrustedInput(source, f"line {line}: TOML nested {depth} deep, more than the {limits.max_depth} allowed")
        line = _line_of_dots(bare, parts - 1)
        raise UntrustedInput(source, f"line {line}: a dotted key of {parts} parts, more than the "
                                     f"{limits.max_key_parts} allowed")
    _check_shape(source, "TOML", limits, depth, items)
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        raise UntrustedInput(source, f"not valid TOML: {e}") from None
    except ValueError as e:  # int() refusing an integer of more than 4300 digits, inside tomllib
        raise UntrustedInput(source, f"not valid TOML: {one_line(str(e), 120)}") from None
    except RecursionError:  # the scan above should make this unreachable; a user error all the same
        raise UntrustedInput(source, "TOML nested too deeply") from None


def load_toml(path: Pathish, limits: InputLimits = CONFIG_TOML, what: str = "TOML file") -> dict[str, Any]:
    """The TOML file at ``path``: a regular file of at most ``limits.max_bytes`` bytes, UTF-8, then
    ``parse_toml``; every failure is one line naming ``path`` (``what`` names its kind)."""
    text = decode_text(read_bytes(path, limits.max_bytes, what), path, what)
    return parse_toml(text, path, limits)


def parse_json(text: str | bytes, source: Pathish, limits: InputLimits = JSON_SIDECAR) -> Any:
    """JSON ``text`` as Python values, bounded like ``parse_toml`` (size, depth, items, before
    parsing); NaN/Infinity (not JSON) and integers of more than 4300 digits are refused."""
    if isinstance(text, bytes | bytearray):
        if len(text) > limits.max_bytes:
            raise UntrustedInput(source, f"{len(text)} bytes of JSON, more than the {limits.max_bytes} allowed")
        text = decode_text(bytes(text), source, "JSON")
    if len(text) > limits.max_bytes:
        raise UntrustedInput(source, f"{len(text)} characters of JSON, more than the {limits.max_bytes} allowed")
    depth, items = json_shape(text)
    if depth > limits.max_depth:
        line = _line_deeper_than(_JSON_DROPPED.sub(lambda m: "s" + "\n" * m.group().count("\n"), text), limits.max_depth)
        raise UntrustedInput(source, f"line {line}: JSON nested {depth} deep, more than the {limits.max_depth} allowed")
    _check_shape(source, "JSON", limits, depth, items)
    try:
        return json.loads(text, parse_constant=_no_constant)
    except json.JSONDecodeError as e:
        raise UntrustedInput(source, f"not valid JSON: {e.msg} (line {e.lineno}, column {e.colno})") from None
    except ValueError as e:  # an integer of too many digits, a NaN
        raise UntrustedInput(source, f"not valid JSON: {one_line(str(e), 120)}") from None
    except RecursionError:
        raise UntrustedInput(source, "JSON nested too deeply") from None


def load_json(path: Pathish, limits: InputLimits = JSON_SIDECAR, what: str = "JSON file") -> Any:
    """The JSON file at ``path``: a regular file of at most ``limits.max_bytes`` bytes, then
    ``parse_json``; every failure is one line naming ``path``."""
    return parse_json(read_bytes(path, limits.max_bytes, what), path, limits)


def _depth(bare: str) -> int:
    brackets = _NOT_BRACKETS.sub("", bare)
    return max(accumulate(map(_STEP.__getitem__, brackets)), default=0)


def _line_deeper_than(bare: str, max_depth: int) -> int:
    """The line where brackets first nest deeper than ``max_depth`` (only on the refusal path)."""
    depth = 0
    for m in re.finditer(r"[\[\]{}]", bare):
        depth += _STEP[m.group()]
        if depth > max_depth:
            return bare.count("\n", 0, m.start()) + 1
    return 1


def _line_of_dots(bare: str, dots: int) -> int:
    """The line of the first segment holding ``dots`` dots (only on the refusal path)."""
    start = 0
    for m in _TOML_SEPARATORS.finditer(bare + "\n"):
        if bare.count(".", start, m.start()) >= dots:
            return bare.count("\n", 0, start) + 1
        start = m.end()
    return 1


def _check_shape(source: Pathish, kind: str, limits: InputLimits, depth: int, items: int) -> None:
    if depth > limits.max_depth:
        raise UntrustedInput(source, f"{kind} nested {depth} deep, more than the {limits.max_depth} allowed")
    if items > limits.max_items:
        raise UntrustedInput(source, f"{kind} of {items} keys and items, more than the {limits.max_items} allowed")


def _no_constant(name: str) -> Any:
    raise ValueError(f"{name} is not a JSON number")
