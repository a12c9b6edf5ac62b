"""Pydantic models read from YAML: one-line errors ``source:line: field.path: problem``.

``parse_yaml_model`` reads YAML text with the limits of ``perception.safe_yaml``, refuses NaN
and infinity anywhere (``first_non_finite``), validates the data as a pydantic model and turns
the first error into one line with the YAML line of the field (``node_line``). A cross-field
check in a model validator raises ``LocatedError`` to name the field it is about. Used by the
scenario, sweep and calibration files alike.
"""

from __future__ import annotations

from typing import Any

import yaml
from pydantic import BaseModel, ValidationError

from lookahead.perception.safe_yaml import YamlError, first_non_finite, load_yaml


class LocatedError(ValueError):
    """A cross-field problem raised by a model validator, with the field it is about."""

    def __init__(self, loc: tuple, message: str) -> None:
        super().__init__(message)
        self.loc = loc


def node_line(node: yaml.Node | None, loc: tuple) -> int | None:
    """1-based line of the YAML key (or sequence item) at ``loc``, or of the deepest one that
    exists (a missing field is reported at its parent's key)."""
    line = None if node is None else node.start_mark.line + 1
    for key in loc:
        if isinstance(node, yaml.MappingNode):
            pair = next(((k, v) for k, v in node.value if k.value == str(key)), None)
            if pair is None:
                break
            line, node = pair[0].start_mark.line + 1, pair[1]
        elif isinstance(node, yaml.SequenceNode) and isinstance(key, int) and 0 <= key < len(node.value):
            node = node.value[key]
            line = node.start_mark.line + 1
        else:
            break
    return line


def field_path(loc: tuple) -> str:
    """A location as a field path: ``mount.height``, ``items[0].x``."""
    return ".".join(f"[{x}]" if isinstance(x, int) else str(x) for x in loc).replace(".[", "[")


def format_validation(
    source: str, err: ValidationError, root: yaml.Node | None = None, drop: tuple = (), under: tuple = (),
) -> str:
    """One line for a pydantic error: ``source[:line]: field.path: message[, got value]``.

    ``drop``: a leading location to leave out (``perception`` for a replay config's ``tracker``);
    ``under``: a location to put in front (``scenario`` for a run record's scenario)."""
    errors = err.errors()
    # an unknown field (a typo) explains the "missing" error that usually comes with it
    first = next((e for e in errors if e["type"] == "extra_forbidden"), errors[0])
    loc = tuple(x for x in first["loc"] if not (isinstance(x, str) and x.startswith("function-")))
    if drop and loc[: len(drop)] == drop:
        loc = loc[len(drop):]
    loc = (*under, *loc)
    msg = first["msg"].removeprefix("Value error, ")
    located = (first.get("ctx") or {}).get("error")
    if isinstance(located, LocatedError):
        loc = (*loc, *located.loc)
    elif first["type"] == "extra_forbidden":
        msg = "unknown field"
    elif "input" in first and first["type"] != "missing" and not isinstance(first["input"], dict | list):
        msg += f", got {first['input']!r}"
    line = node_line(root, loc) if loc else None
    where = f"{source}:{line}" if line else source
    more = f" (and {err.error_count() - 1} more)" if err.error_count() > 1 else ""
    return f"{where}: {field_path(loc) or '(top level)'}: {msg}{more}"


def parse_yaml_model(
    text: str, source: str, model: type[BaseModel], what: str, error: type[ValueError] = ValueError
) -> Any:
    """Validate YAML ``text`` as pydantic ``model``; a one-line ``error`` naming ``source:line``
    and the field when the YAML or a value is wrong."""
    try:
        data, root = load_yaml(text, source)
    except YamlError as e:
        raise error(str(e)) from None
    if not isinstance(data, dict):
        raise error(f"{source}: expected a mapping of {what} fields, got {type(data).__name__}")
    bad = first_non_finite(data)
    if bad is not None:
        loc, value = bad
        line = node_line(root, loc)
        raise error(f"{source}{f':{line}' if line else ''}: {field_path(loc)}: expected a finite number, got {value!r}")
    try:
        return model.model_validate(data)
    except ValidationError as e:
        raise error(format_validation(source, e, root).replace(": (top level): ", ": ")) from None
