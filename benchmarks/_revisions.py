"""Shared by the before/after benchmarks: the package as of a git revision, and a child process.

A before/after timing runs each version in a fresh single-threaded process on the same inputs:
:func:`package_at` extracts a revision's ``tyrebayes`` and ``models`` with ``git archive``, and
:func:`run_child` runs a measurement script on the package at that folder (or on this checkout)
and returns the JSON object its last line prints.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def package_at(
    revision: str, folder: Path, paths: tuple[str, ...] = ("tyrebayes", "models")
) -> Path:
    """``tyrebayes`` and ``models`` (or ``paths``) as of git ``revision``, extracted in ``folder``.

    A child that also imports the benchmarks' helpers (``_online_common``) takes them from the
    same revision (``paths`` with ``"benchmarks"``): they import the package as it was then.
    """
    folder.mkdir(parents=True, exist_ok=True)
    archive = subprocess.run(
        ["git", "archive", revision, *paths],
        cwd=ROOT,
        capture_output=True,
        check=True,
    ).stdout
    subprocess.run(["tar", "-x", "-C", str(folder)], input=archive, check=True)
    return folder


def run_child(source: str, args: list, code: Path | None, env: dict[str, str]) -> dict:
    """Run ``python -c source *args`` on the package at ``code`` (default this checkout).

    ``env`` is added to this process's environment. Returns the JSON object of the child's last
    line of output; a failed child raises with its stderr.
    """
    result = subprocess.run(
        [sys.executable, "-c", source, *map(str, args)],
        capture_output=True,
        text=True,
        env={**os.environ, **env, "PYTHONPATH": str(code or ROOT)},
        cwd=str(code or ROOT),
    )
    if result.returncode != 0:
        raise RuntimeError(f"measurement failed:\n{result.stderr}")
    return json.loads(result.stdout.strip().splitlines()[-1])
