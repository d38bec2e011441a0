"""The command's child process reports its own peak memory, not its parent's."""

from __future__ import annotations

import math
import subprocess
import sys

import numpy as np
import pytest

from benchmarks._cli_child import cli_command, peak_mb


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="VmHWM is Linux's")
def test_a_child_of_a_large_process_reports_its_own_peak():
    held = np.ones(600 * 2**20 // 8)  # 600 MB resident in this process while the child runs
    child = subprocess.run(cli_command(["--help"]), capture_output=True, text=True)
    assert child.returncode == 0, child.stderr[-300:]
    peak = peak_mb(child.stderr)
    assert math.isfinite(peak) and 10.0 < peak < 400.0, peak
    assert held.sum() > 0


def test_a_child_that_said_nothing_has_no_peak():
    assert math.isnan(peak_mb("Traceback ...\n"))
