"""The ``tyrebayes`` command in a child process that reports its own peak memory at exit.

``resource.getrusage``'s ``ru_maxrss`` survives ``execve`` on Linux: a child started by
``subprocess`` (vfork + exec) starts its count from the parent's high-water mark, so a benchmark
that simulated an hour before starting the command would report its own peak as the command's.
The kernel's ``VmHWM`` (``/proc/self/status``) belongs to the exec'd process's own memory map;
the child writes it to stderr as it exits, and :func:`peak_mb` reads it back.

Examples
--------
>>> cmd = cli_command(["--version"])
>>> cmd[1], cmd[3]
('-c', '--version')
>>> peak_mb("progress\\nPEAK_RSS_KB 2048\\n")
2.0
"""

from __future__ import annotations

import math
import sys

_WRAPPER = (
    "import sys\n"
    "from tyrebayes.cli import main\n"
    "try:\n"
    "    code = main(sys.argv[1:])\n"
    "finally:\n"
    "    kb = None\n"
    "    try:\n"
    "        with open('/proc/self/status') as fh:\n"
    "            kb = next(int(ln.split()[1]) for ln in fh if ln.startswith('VmHWM:'))\n"
    "    except (OSError, StopIteration):\n"
    "        import resource\n"
    "        kb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss\n"
    "    sys.stderr.write('PEAK_RSS_KB %d\\n' % kb)\n"
    "sys.exit(code)\n"
)


def cli_command(args: list[str]) -> list[str]:
    """The command line that runs ``tyrebayes ARGS`` and reports its peak (:func:`peak_mb`)."""
    return [sys.executable, "-c", _WRAPPER, *args]


def peak_mb(stderr: str) -> float:
    """The child's own peak resident memory [MB] from its stderr (NaN if it did not say)."""
    lines = [ln for ln in stderr.splitlines() if ln.startswith("PEAK_RSS_KB ")]
    return float(lines[-1].split()[1]) / 1024.0 if lines else math.nan
