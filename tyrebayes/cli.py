"""The ``tyrebayes`` command.

Each sub-command lives in ``tyrebayes/_commands/<name>.py`` and exposes ``register(subparsers)``,
which adds its parser and sets ``func``; ``func(args)`` returns the exit code. Bad input raises
:class:`tyrebayes.BadInputError` and becomes exit code 2 with one line on stderr; SIGINT and
SIGTERM end any command with exit code 130 / 143 and one line (:func:`main`).
"""

from __future__ import annotations

import argparse
import contextlib
import importlib
import io
import os
import signal
import sys
from typing import NoReturn

from . import _interrupts
from ._errors import BadInputError

# Order is the order shown in ``tyrebayes --help``.
_COMMAND_MODULES = (
    "demo",
    "convert",
    "inspect",
    "fit_tyre",
    "online",
    "fleet",
    "fleet_run",
    "wear",
    "fit_wear",
    "vmax",
    "criticize",
    "report",
)


class _Parser(argparse.ArgumentParser):
    """An argument parser whose errors are one line on stderr (exit 2), like every bad input.

    argparse prints the whole usage before the reason; with a dozen options that is five lines
    in which the reason comes last. Sub-command parsers are made of the same class.
    """

    def error(self, message: str) -> NoReturn:
        self.exit(2, f"{self.prog}: {message} (see {self.prog} --help)\n")


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(
        prog="tyrebayes",
        description="Tyre parameters with honest uncertainty from ordinary vehicle sensors.",
    )
    subparsers = parser.add_subparsers(dest="command", required=True)
    # The command modules load NumPy, JAX and Arrow: compiled code that a signal must not cut
    # (and whose helper threads, started here, then never take one).
    with _interrupts.blocked():
        for name in _COMMAND_MODULES:
            try:
                module = importlib.import_module(f"tyrebayes._commands.{name}")
            except ModuleNotFoundError as err:
                if err.name == f"tyrebayes._commands.{name}":
                    continue  # command not built in this installation
                raise
            module.register(subparsers)
    return parser


def _quiet_closing_logs() -> None:
    """On the first signal: a closing dask cluster's warnings would bury the one line."""
    import logging

    for name in ("distributed", "tornado", "asyncio"):
        logging.getLogger(name).setLevel(logging.CRITICAL + 1)


def main(argv: list[str] | None = None) -> int:
    """Run the command line; returns the exit status.

    0 ok; 2 bad input; 3 a fit that did not converge; 4 ``fleet-run`` finished with failed
    items; 130 / 143 stopped by SIGINT (Ctrl-C) / SIGTERM.

    Bad input (:class:`BadInputError`, and an operating-system error on a named file such as a
    full disk or a vanished folder) is one line on stderr and exit 2. A signal is one line too
    (``tyrebayes CMD: interrupted (SIGINT)``), after the clean-up it triggers: temporary files
    removed, a previous output left as it was (:mod:`tyrebayes._interrupts`). A closed stdout
    (``--json | head``) ends the command quietly. When it owns the process (it read
    ``sys.argv``: the ``tyrebayes`` script), a signal after the command finished, while Python
    exits, ends the process at once with the command's own status.
    """
    with _interrupts.signals_as_interruptions(until_exit=argv is None):
        code = _run(argv)
        _interrupts.set_exit_status(code)
        return code


def _run(argv: list[str] | None) -> int:
    """:func:`main` inside its signal handling."""
    command = "tyrebayes"
    _interrupts.on_interrupt(_quiet_closing_logs)
    try:
        args = build_parser().parse_args(argv)
        command = f"tyrebayes {args.command}"
        try:
            code = int(args.func(args))
            _interrupts.check()  # one that code on the way swallowed: not a success
            sys.stdout.flush()  # a closed pipe shows here, not in the interpreter's exit
            return code
        except BadInputError as err:
            if _interrupts.pending() is not None:
                raise
            print(f"{command}: {err}", file=sys.stderr)
            return 2
        except BrokenPipeError:
            raise
        except OSError as err:
            if err.filename is None or _interrupts.pending() is not None:
                raise  # not about a file the user named: a bug, keep its traceback
            print(
                f"{command}: expected a usable file, got '{err.filename}' ({err.strerror or err})",
                file=sys.stderr,
            )
            return 2
    except BrokenPipeError:
        # The reader went away (``| head``): the output it wanted was written. Point stdout
        # at /dev/null so that the interpreter's final flush does not raise again.
        _silence_stdout()
        return 1
    except BaseException as err:
        signum = _interruption(err)
        if signum is None:
            raise
        print(f"{command}: interrupted ({signal.Signals(signum).name})", file=sys.stderr)
        if argv is None:
            _exit_now(128 + signum)
        with contextlib.suppress(Exception):
            sys.stdout.flush()
        return 128 + signum


def _exit_now(status: int) -> NoReturn:
    """End the process after a signal without the interpreter's teardown.

    A signal raised inside JAX's machinery (a Python step of a C++ dispatch or trace) can leave
    its runtime half-way; the teardown's clearing of its caches then crashed ``online`` with a
    segmentation fault after the one line (2 of 2 Ctrl-C's). Every ``finally`` block and
    context manager has run by now (temporary files removed, a cluster closed); what is skipped
    is the exit handlers, so the ones that matter run here: the output streams and the log
    handlers are flushed, and multiprocessing's (a closed cluster's semaphores released, which
    its resource tracker otherwise reports as leaked). Only when :func:`main` owns the process
    (it read ``sys.argv``), never for a caller.
    """
    import logging

    for stream in (sys.stdout, sys.stderr):
        with contextlib.suppress(Exception):
            stream.flush()
    with contextlib.suppress(Exception):
        logging.shutdown()
    if "multiprocessing" in sys.modules:
        with contextlib.suppress(Exception):
            from multiprocessing import util

            util._exit_function()
    os._exit(status)


def _interruption(err: BaseException) -> int | None:
    """The signal that ended the command, or None for an error that is not one.

    Any exception after a signal is taken for its consequence (a dask connection closed under
    a task, a library's own error around a ``KeyboardInterrupt``), and a plain
    ``KeyboardInterrupt`` (raised by a library that installed its own handler) is SIGINT.
    """
    if isinstance(err, _interrupts.Interrupted):
        return err.signum
    if _interrupts.pending() is not None:
        return _interrupts.pending()
    if isinstance(err, KeyboardInterrupt):
        return int(signal.SIGINT)
    return None


def _silence_stdout() -> None:
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    except (OSError, ValueError, io.UnsupportedOperation):
        pass  # stdout is not a file descriptor (tests capture it): nothing left to flush


if __name__ == "__main__":
    sys.exit(main())
