"""Run the ``lookahead`` typer app inside the test process, close to how its console script runs.

A child process per invocation costs Python's start-up and the command's imports (1-3 s of CPU
each); inside the test process those are paid once. ``invoke`` keeps what a child process would
have shown the user:

* exit code (``SystemExit``), stdout and stderr (typer's ``CliRunner``, stderr separate);
* anything written straight to file descriptors 1 and 2 (C libraries, ``sys.__stderr__``);
* warnings the interpreter shows by default (not Deprecation / PendingDeprecation / Import /
  Resource warnings), and WARNING+ log records, formatted as ``main()``'s ``basicConfig`` does;
* an exception escaping the app: exit code 1 and its traceback on stderr (what the user would see);
* a timeout (``SIGALRM``; main thread only): ``exit_code`` None;
* the test process as it was: working directory, environment variables, SIGALRM, logging;
* the peak RSS the command added to the process (VmHWM reset via /proc/self/clear_refs where the
  kernel allows it, else the rise of ``ru_maxrss``).

It cannot cap the memory of a hostile input (no RLIMIT_AS of its own): inputs that may explode
belong in a real child process (``malformed_cases.run_cli``).
"""

from __future__ import annotations

import io
import logging
import os
import resource
import signal
import sys
import tempfile
import time
import traceback
import warnings
from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from typer.testing import CliRunner

#: what a child process started with PYTHONWARNINGS=ignore::DeprecationWarning does not print
HIDDEN_WARNINGS = (DeprecationWarning, PendingDeprecationWarning, ImportWarning, ResourceWarning)
#: the environment of the console-script runs (``run_cli``): wide lines, no colour
CLI_ENV: dict[str, str | None] = {"COLUMNS": "120", "NO_COLOR": "1", "FORCE_COLOR": None}


class CliTimeout(BaseException):
    """Raised in the main thread when an in-process invocation runs past its timeout."""


@dataclass
class InProcessResult:
    args: list[str]
    exit_code: int | None  # None: stopped at the timeout
    stdout: str
    stderr: str
    wall_s: float
    cpu_s: float
    peak_rss_added_bytes: int  # peak RSS during the call minus RSS before it (0 if unknown)


def _status_kb(key: str) -> int:
    try:
        for line in Path("/proc/self/status").read_text().splitlines():
            if line.startswith(key + ":"):
                return int(line.split()[1])
    except (OSError, ValueError, IndexError):
        pass
    return 0


def _reset_peak_rss() -> bool:
    try:
        Path("/proc/self/clear_refs").write_text("5")  # resets VmHWM to VmRSS (Linux >= 4.0)
        return True
    except OSError:
        return False


@contextmanager
def _fd_to_file(fd: int, sink: Any) -> Iterator[None]:
    for stream in (sys.__stdout__, sys.__stderr__):
        if stream is not None:
            stream.flush()
    saved = os.dup(fd)
    os.dup2(sink.fileno(), fd)
    try:
        yield
    finally:
        for stream in (sys.__stdout__, sys.__stderr__):
            if stream is not None:
                stream.flush()
        os.dup2(saved, fd)
        os.close(saved)


def invoke(app: Any, args: list[str], cwd: Path, timeout: float,
           env: Mapping[str, str | None] = CLI_ENV) -> InProcessResult:
    """``app(args)`` in this process with ``cwd`` as the working directory, stopped at ``timeout``."""
    runner = CliRunner()
    log_text = io.StringIO()
    handler = logging.StreamHandler(log_text)
    handler.setLevel(logging.WARNING)
    handler.setFormatter(logging.Formatter("%(levelname)s %(name)s: %(message)s"))
    root = logging.getLogger()
    old_level, old_cwd, old_environ = root.level, os.getcwd(), dict(os.environ)

    def on_alarm(signum: int, frame: Any) -> None:
        raise CliTimeout

    exit_code: int | None
    stdout = stderr = ""
    with tempfile.TemporaryFile() as fd1, tempfile.TemporaryFile() as fd2, \
            warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        old_alarm = signal.signal(signal.SIGALRM, on_alarm)
        os.chdir(cwd)
        root.addHandler(handler)
        root.setLevel(logging.WARNING)
        rss0 = _status_kb("VmRSS")
        hwm_reset = _reset_peak_rss()
        ru0 = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
        cpu0, t0 = time.process_time(), time.monotonic()
        try:
            signal.setitimer(signal.ITIMER_REAL, timeout)
            with _fd_to_file(1, fd1), _fd_to_file(2, fd2):
                res = runner.invoke(app, args, env=dict(env), catch_exceptions=False)
            exit_code, stdout, stderr = res.exit_code, res.stdout, res.stderr
        except CliTimeout:
            exit_code = None
        except Exception:  # escaped the app: the console script would print this traceback, exit 1
            exit_code, stderr = 1, traceback.format_exc()
        finally:
            signal.setitimer(signal.ITIMER_REAL, 0)
            wall, cpu = time.monotonic() - t0, time.process_time() - cpu0
            signal.signal(signal.SIGALRM, old_alarm)
            os.chdir(old_cwd)
            if dict(os.environ) != old_environ:  # what the command set stays with it, as in a child
                os.environ.clear()
                os.environ.update(old_environ)
            root.removeHandler(handler)
            root.setLevel(old_level)
        if hwm_reset:
            peak_kb = _status_kb("VmHWM") - rss0
        else:
            ru1 = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
            peak_kb = ru1 - rss0 if ru1 > ru0 else 0
        fd1.seek(0)
        fd2.seek(0)
        stdout += fd1.read().decode("utf-8", "replace")
        extra_err = fd2.read().decode("utf-8", "replace")
        shown = [w for w in caught if not issubclass(w.category, HIDDEN_WARNINGS)]
    stderr += extra_err + "".join(warnings.formatwarning(w.message, w.category, w.filename, w.lineno, w.line)
                                  for w in shown) + log_text.getvalue()
    return InProcessResult(args=list(args), exit_code=exit_code, stdout=stdout, stderr=stderr, wall_s=wall,
                           cpu_s=cpu, peak_rss_added_bytes=max(0, peak_kb) * 1024)
