"""The ``tyrebayes`` command.

Each sub-command lives in ``tyrebayes/_commands/<name>.py`` and exposes ``register(subparsers)``,
which adds its parser and sets ``func``; ``func(args)`` returns the exit code. Bad input raises
:class:`tyrebayes.BadInputError` and becomes exit code 2 with one line on stderr.
"""

from __future__ import annotations

import argparse
import importlib
import io
import os
import signal
import sys
import threading
from typing import NoReturn

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
    for name in _COMMAND_MODULES:
        try:
            module = importlib.import_module(f"tyrebayes._commands.{name}")
        except ModuleNotFoundError as err:
            if err.name == f"tyrebayes._commands.{name}":
                continue  # command not built in this installation
            raise
        module.register(subparsers)
    return parser


def _terminate(signum: int, frame) -> NoReturn:
    # SIGTERM as an exception: the writers' ``finally`` blocks then remove their temporary files.
    raise SystemExit(128 + signum)


def _on_sigterm(handler):
    """Install a SIGTERM handler and return the previous one (a no-op off the main thread)."""
    if threading.current_thread() is not threading.main_thread():
        return None
    # None: the previous handler was not set from Python; restore the default then.
    return signal.signal(signal.SIGTERM, signal.SIG_DFL if handler is None else handler)


def main(argv: list[str] | None = None) -> int:
    """Run the command line; returns the exit status (0 ok, 2 bad input, 3 not converged).

    Bad input (:class:`BadInputError`, and an operating-system error on a named file such as a
    full disk or a vanished folder) is one line on stderr and exit 2. A closed stdout (``--json |
    head``) ends the command quietly.
    """
    try:
        args = build_parser().parse_args(argv)
        previous = _on_sigterm(_terminate)
        try:
            code = int(args.func(args))
            sys.stdout.flush()  # a closed pipe shows here, not in the interpreter's exit
            return code
        except BadInputError as err:
            print(f"tyrebayes {args.command}: {err}", file=sys.stderr)
            return 2
        except BrokenPipeError:
            raise
        except OSError as err:
            if err.filename is None:
                raise  # not about a file the user named: a bug, keep its traceback
            print(
                f"tyrebayes {args.command}: expected a usable file, got '{err.filename}' "
                f"({err.strerror or err})",
                file=sys.stderr,
            )
            return 2
        finally:
            _on_sigterm(previous)
    except BrokenPipeError:
        # The reader went away (``| head``): the output it wanted was written. Point stdout at
        # /dev/null so that the interpreter's final flush does not raise again.
        _silence_stdout()
        return 1


def _silence_stdout() -> None:
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    except (OSError, ValueError, io.UnsupportedOperation):
        pass  # stdout is not a file descriptor (tests capture it): nothing left to flush


if __name__ == "__main__":
    sys.exit(main())
