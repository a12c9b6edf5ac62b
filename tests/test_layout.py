"""Rules of the code's layout that no linter checks: checked here on the source itself.

The package layers and the wings of ``tools/`` are import-linter contracts (``make test``
runs ``lint-imports``); these are the two rules beside them:

- no module imports a private name (``_name``) from another module;
- ``tools/cli.py`` is the only module that prints or exits (``print``, ``sys.exit``,
  ``typer.Exit``, a rich ``Console``); everything else returns or raises.
"""

from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("perception", "intent", "sim", "tools")
CLI = ROOT / "tools" / "cli.py"


def modules() -> list[Path]:
    return sorted(p for pkg in PACKAGES for p in (ROOT / pkg).rglob("*.py"))


def test_no_module_imports_a_private_name_from_another() -> None:
    found = []
    for path in modules():
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            if isinstance(node, ast.ImportFrom) and node.module and node.module.startswith("lookahead."):
                found += [f"{path.relative_to(ROOT)}:{node.lineno}: {node.module}.{a.name}"
                          for a in node.names if a.name.startswith("_")]
    assert not found, "\n".join(found)


def prints_or_exits(tree: ast.AST) -> list[int]:
    """Lines that call ``print``, ``sys.exit``, ``typer.Exit`` or ``Console``."""
    lines = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Call):
            f = node.func
            name = f.id if isinstance(f, ast.Name) else f.attr if isinstance(f, ast.Attribute) else ""
            owner = f.value.id if isinstance(f, ast.Attribute) and isinstance(f.value, ast.Name) else ""
            if name in ("print", "Console") and not owner or (owner, name) in (("sys", "exit"), ("typer", "Exit")):
                lines.append(node.lineno)
    return lines


def test_only_the_cli_prints_or_exits() -> None:
    found = [f"{p.relative_to(ROOT)}:{line}" for p in modules() if p != CLI
             for line in prints_or_exits(ast.parse(p.read_text(), str(p)))]
    assert not found, "\n".join(found)
    assert prints_or_exits(ast.parse(CLI.read_text()))  # the rule sees the CLI's own printing
