"""YAML a user hands over, read with limits before any work (scenarios, suites, sweeps, configs).

``load_yaml`` parses the text once with libyaml's safe loader (the pure-Python one when
libyaml is missing), checks the node graph, and only then builds Python objects:

- at most ``MAX_YAML_BYTES`` of text (``read_yaml_text`` checks the file's size before reading);
- at most ``MAX_DEPTH`` levels of nesting (libyaml itself stops at 1000);
- at most ``MAX_NODES`` nodes once aliases are expanded: an anchor used many times counts at
  every use, so a "billion laughs" file is refused from its node graph in milliseconds,
  before anything is built (aliases stay allowed for ordinary reuse);
- no alias cycles, no duplicate keys in a mapping (YAML forbids them; PyYAML keeps the last).

Every refusal is a ``YamlError`` whose ``str()`` is one line ``source:line: problem``.
``first_non_finite`` finds a NaN or infinite number in parsed data, with its location, for
readers that validate the data against a model.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import yaml

MAX_YAML_BYTES = 4 * 2**20  # a scenario is a few kB; the largest packaged sweep about 2 kB
MAX_DEPTH = 64
MAX_NODES = 200_000

LOADER: type = getattr(yaml, "CSafeLoader", yaml.SafeLoader)
MERGE_TAG = "tag:yaml.org,2002:merge"


class YamlError(ValueError):
    """YAML that cannot be used; ``str()`` is one line ``source[:line]: problem``. ``problem`` and
    ``line`` and ``column`` (1-based, or None) let a caller word it otherwise (an option's value)."""

    def __init__(self, source: str, problem: str, mark: yaml.Mark | None = None) -> None:
        super().__init__(f"{source}:{mark.line + 1}: {problem}" if mark is not None else f"{source}: {problem}")
        self.problem = problem
        self.line = mark.line + 1 if mark is not None else None
        self.column = mark.column + 1 if mark is not None else None


class _GraphCheck:
    """Depth, expanded size, alias cycles and duplicate keys of a composed node graph."""

    def __init__(self, source: str, max_depth: int, max_nodes: int) -> None:
        self.source, self.max_depth, self.max_nodes = source, max_depth, max_nodes
        self.size: dict[int, int] = {}  # id(node) -> nodes in its expansion
        self.open: set[int] = set()

    def fail(self, node: yaml.Node, problem: str) -> YamlError:
        return YamlError(self.source, problem, getattr(node, "start_mark", None))

    def expanded(self, node: yaml.Node, depth: int) -> int:
        key = id(node)
        if key in self.size:  # an alias: its expansion counts again at this use
            return self.size[key]
        if key in self.open:
            raise self.fail(node, "an alias refers to a node that contains it (a cycle)")
        if depth > self.max_depth:
            raise self.fail(node, f"nested more than {self.max_depth} levels deep")
        self.open.add(key)
        n = 1
        if isinstance(node, yaml.SequenceNode):
            n += sum(self.expanded(child, depth + 1) for child in node.value)
        elif isinstance(node, yaml.MappingNode):
            seen: set[tuple[str, str]] = set()
            for k, v in node.value:
                if isinstance(k, yaml.ScalarNode) and k.tag != MERGE_TAG:
                    if (k.tag, k.value) in seen:
                        raise self.fail(k, f"duplicate key {k.value!r}")
                    seen.add((k.tag, k.value))
                n += self.expanded(k, depth + 1) + self.expanded(v, depth + 1)
        self.open.discard(key)
        if n > self.max_nodes:
            raise self.fail(node, f"aliases expand to more than {self.max_nodes} nodes")
        self.size[key] = n
        return n


def _malformed(source: str, e: yaml.YAMLError) -> YamlError:
    problem = getattr(e, "problem", None) or str(e).splitlines()[0]
    return YamlError(source, f"malformed YAML: {problem}", getattr(e, "problem_mark", None))


def load_yaml(
    text: str, source: str = "<string>", *, max_depth: int = MAX_DEPTH, max_nodes: int = MAX_NODES,
) -> tuple[Any, yaml.Node | None]:
    """(data, root node) of one YAML document, checked before it is built; ``YamlError`` when not.

    The root node's marks give line numbers for later errors (``None`` for an empty document).
    """
    if len(text) > MAX_YAML_BYTES:
        raise YamlError(source, f"{len(text)} characters of YAML, more than the {MAX_YAML_BYTES} allowed")
    loader = LOADER(text)
    try:
        root = loader.get_single_node()
        if root is None:
            return None, None
        _GraphCheck(source, max_depth, max_nodes).expanded(root, 0)
        return loader.construct_document(root), root
    except yaml.YAMLError as e:
        raise _malformed(source, e) from None
    except RecursionError:
        raise YamlError(source, "nested too deeply") from None
    finally:
        loader.dispose()


def read_yaml_text(path: str | Path, what: str = "YAML", max_bytes: int = MAX_YAML_BYTES) -> str:
    """The UTF-8 text of a YAML file, its size checked before it is read; ``YamlError`` (one
    line naming the file) when it is missing, not a regular file, too large or not text."""
    p = Path(path)
    if not p.is_file():
        raise YamlError(str(p), f"no such {what} file")
    try:
        size = p.stat().st_size
        if size > max_bytes:
            raise YamlError(str(p), f"{size} bytes, more than the {max_bytes} a {what} file may have")
        return p.read_text(encoding="utf-8")
    except OSError as e:
        raise YamlError(str(p), f"cannot read: {e.strerror or e}") from None
    except UnicodeDecodeError as e:
        raise YamlError(str(p), f"not UTF-8 text (byte {e.start})") from None


def first_non_finite(data: Any, loc: tuple = ()) -> tuple[tuple, float] | None:
    """(location, value) of the first NaN or infinite float in nested lists and mappings, else None."""
    if isinstance(data, float):
        return None if math.isfinite(data) else (loc, data)
    if isinstance(data, dict):
        items = data.items()
    elif isinstance(data, list | tuple):
        items = enumerate(data)
    else:
        return None
    for k, v in items:
        found = first_non_finite(v, (*loc, k))
        if found is not None:
            return found
    return None
