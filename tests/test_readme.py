"""The README's Python quick start runs as written, on a simulated drive and fleet.

It runs in a fresh interpreter, as a user's script would: without this suite's
``tests/conftest.py`` (which turns on float64 and more), so it shows that ``import tyrebayes``
sets up what the package needs.
"""

import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from tyrebayes._domain import load_vehicle
from tyrebayes.simulate.drive import simulate_drive
from tyrebayes.simulate.fleet import simulate_fleet
from tyrebayes.streams import write_stream

pytestmark = pytest.mark.early  # minutes long: started first (tests/conftest.py)

README = Path(__file__).resolve().parents[1] / "README.md"


def _quick_start() -> str:
    blocks = re.findall(r"```python\n(.*?)```", README.read_text(encoding="utf-8"), re.S)
    assert blocks, "README.md has no ```python block"
    return blocks[0]


def test_readme_quick_start_runs(tmp_path):
    vehicle = load_vehicle("suv_rav4")
    drive, _ = simulate_drive(0, vehicle, "winter", duration_s=120.0)
    write_stream(drive, tmp_path / "drive.parquet")
    table, _ = simulate_fleet(0, 26)
    table.to_csv(tmp_path / "fleet.csv", index=False)

    run = subprocess.run(
        [sys.executable, "-c", _quick_start()],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=1800,
    )

    assert run.returncode == 0, run.stderr[-3000:]
    lines = run.stdout.strip().splitlines()
    assert len(lines) == 2
    assert "'mean'" in lines[0] and lines[0].endswith(("True", "False"))
    assert lines[1] in ("ok", "warn", "insufficient_evidence")
    assert np.isfinite(float(re.search(r"'mean': ([0-9.e+-]+)", lines[0]).group(1)))
