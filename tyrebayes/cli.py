"""The ``tyrebayes`` command.

Each sub-command lives in ``tyrebayes/_commands/<name>.py`` and exposes ``register(subparsers)``,
which adds its parser and sets ``func``; ``func(args)`` returns the exit code. Bad input raises
:class:`tyrebayes.BadInputError` and becomes exit code 2 with one line on stderr.
"""

from __future__ import annotations

import argparse
import importlib
import sys

from ._errors import BadInputError

# Order is the order shown in ``tyrebayes --help``.
_COMMAND_MODULES = (
    "demo",
    "convert",
    "inspect",
    "fit_tyre",
    "fleet",
    "wear",
    "vmax",
    "criticize",
    "report",
)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
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


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.func(args))
    except BadInputError as err:
        print(f"tyrebayes {args.command}: {err}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
