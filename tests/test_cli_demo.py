"""``tyrebayes demo --quick`` end to end, and ``tyrebayes report`` on bad and good input."""

from __future__ import annotations

import json
import re
import struct
from pathlib import Path

import pytest

from tyrebayes.cli import main

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"

# The demo is an integration run: numerical warnings inside fits (a draw overflowing, high Pareto
# k) are reported in its diagnostics table, not turned into test errors.
pytestmark = [
    pytest.mark.early,  # minutes long: started first (tests/conftest.py)
    pytest.mark.filterwarnings("ignore::RuntimeWarning"),
    pytest.mark.filterwarnings("ignore::UserWarning"),
]


def _png_size(path: Path) -> tuple[int, int]:
    data = path.read_bytes()
    assert data[:8] == PNG_MAGIC, f"{path} is not a PNG"
    width, height = struct.unpack(">II", data[16:24])
    return width, height


@pytest.fixture(scope="module")
def demo_dir(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("demo")
    assert main(["demo", "--quick", "--out", str(out)]) == 0
    return out


def test_demo_writes_report_and_figures(demo_dir: Path) -> None:
    html = (demo_dir / "report.html").read_text()
    md = (demo_dir / "report.md").read_text()
    figures = sorted((demo_dir / "figures").glob("*.png"))
    names = {p.stem for p in figures}
    assert {
        "tyre_curves",
        "friction_vs_inverse_stiffness",
        "vmax",
        "wear_vs_temperature",
        "warnings",
        "lateral_curves",
    } <= names
    for p in figures:
        w, h = _png_size(p)
        assert p.stat().st_size > 5_000 and w > 300 and h > 200, p
    # every image and link of both documents resolves
    for src in re.findall(r'(?:src|href)="([^"]+)"', html):
        if src.startswith("data:image/png;base64,"):
            assert len(src) > 5_000
        else:
            assert (demo_dir / src).is_file(), src
    assert html.count("data:image/png;base64,") == len(figures)
    for link in re.findall(r"!\[[^\]]*\]\(([^)]+)\)", md):
        assert (demo_dir / link).is_file(), link
    # the sections are there and carry numbers
    for heading in (
        "Per-tyre posteriors",
        "Cornering",
        "Friction against 1/C_xr",
        "V_max",
        "wear",
        "Warnings",
        "Diagnostics",
        "criticism",
    ):
        assert heading.lower() in html.lower() and heading.lower() in md.lower(), heading
    assert re.search(r"R² = 0\.\d\d", md)
    assert "<td>nan</td>" not in html


def test_demo_numbers_are_computed(demo_dir: Path) -> None:
    summary = json.loads((demo_dir / "report.json").read_text())
    assert len(summary["tyres"]) >= 5
    for t in summary["tyres"]:
        assert t["summary"]["c_xr"]["mean"] > 0
    assert 0.0 <= summary["fleet"]["ols"]["r2"] <= 1.0
    assert len(summary["vmax"]["sets"]) >= 6
    assert all(0.0 <= w["probability"] <= 1.0 for w in summary["warnings"])
    assert {"winter", "summer"} <= set(summary["wear"]["kappa"])
    assert summary["criticism"] and summary["diagnostics"]
    (lateral,) = summary["laterals"]
    assert lateral["summary"]["converged"] and lateral["summary"]["c_y_front"]["mean"] > 0
    # the fits are saved for ``tyrebayes report``
    assert sorted((demo_dir / "fits").glob("*.nc"))


def test_report_from_saved_fits(demo_dir: Path, tmp_path: Path) -> None:
    fits = sorted((demo_dir / "fits").glob("*.nc"))
    tyre = next(p for p in fits if p.name.startswith("tyre_winter"))
    fleet = demo_dir / "fits" / "fleet.nc"
    out = tmp_path / "rep"
    assert main(["report", str(tyre), str(fleet), "--type", "winter", "--out", str(out)]) == 0
    html = (out / "report.html").read_text()
    assert "Warnings" in html and "Friction against 1/C_xr" in html
    assert (out / "figures" / "tyre_curves.png").stat().st_size > 5_000


def test_report_bad_input(tmp_path: Path, capsys) -> None:
    assert main(["report", str(tmp_path / "missing.nc"), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "missing.nc" in err[0]
    junk = tmp_path / "junk.nc"
    junk.write_text("not a netcdf")
    assert main(["report", str(junk), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "junk.nc" in err[0]
