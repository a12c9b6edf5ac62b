"""Shared by the tools tests: the ``lookahead`` command line, run in-process."""

from __future__ import annotations

import sys
from collections.abc import Callable

import pytest
from typer.testing import CliRunner

from lookahead.tools.cli import app


@pytest.fixture
def lookahead() -> Callable[..., int]:
    """``lookahead(*args)`` runs the command line in-process and returns its exit code; what it
    printed goes to this test's stdout / stderr, so ``capsys`` reads it."""

    def call(*args: object) -> int:
        res = CliRunner().invoke(app, [str(a) for a in args])
        sys.stdout.write(res.stdout)
        sys.stderr.write(res.stderr)
        return res.exit_code

    return call
