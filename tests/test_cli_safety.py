"""The command line fails cleanly: argument errors, output paths, closed pipes, signals.

Every case fails before any fit (a stub in place of the fitter proves it never ran) and ends
with one line on stderr and exit 2, or, for a closed pipe, quietly.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys

import pandas as pd
import pytest

import tyrebayes.inference.fleet
from tyrebayes._commands import wear
from tyrebayes._domain import load_vehicle
from tyrebayes._resources import models_dir
from tyrebayes.cli import main
from tyrebayes.streams import write_stream
from tyrebayes.streams.synthetic import synthetic_stream


def _one_line_error(capsys, argv) -> str:
    code = main(argv)
    err = capsys.readouterr().err
    assert code == 2, err
    assert err.count("\n") == 1, err
    return err


@pytest.fixture
def no_fleet_fit(monkeypatch):
    def fail(*args, **kwargs):
        raise AssertionError("the fit ran before the output path was checked")

    monkeypatch.setattr(tyrebayes.inference.fleet, "fit_fleet", fail)


@pytest.fixture
def table(tmp_path):
    path = tmp_path / "fleet.csv"
    path.write_text("tyre_id,tyre_type,c_xr,mu\na,winter,40,0.3\n")
    return str(path)


# --- argparse errors ---------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("argv", "needle"),
    [
        (["predict", "f.nc", "--c-xr", "40", "--type", "summr"], "invalid choice: 'summr'"),
        (["predict", "f.nc", "--type", "winter"], "required: --c-xr"),
        (["warn", "f.nc", "--c-xr", "forty", "--type", "winter"], "invalid float value"),
        (["no-such-command"], "invalid choice: 'no-such-command'"),
        ([], "required: command"),
    ],
)
def test_argument_errors_are_one_line(capsys, argv, needle):
    with pytest.raises(SystemExit) as info:
        main(argv)
    err = capsys.readouterr().err
    assert info.value.code == 2
    assert err.count("\n") == 1 and needle in err, err
    assert err.startswith("tyrebayes")


def test_help_is_still_whole(capsys):
    with pytest.raises(SystemExit) as info:
        main(["predict", "--help"])
    assert info.value.code == 0
    assert "--c-xr" in capsys.readouterr().out


# --- output paths, checked before the work -----------------------------------------------------


def test_fit_fleet_out_on_an_existing_folder(capsys, tmp_path, table, no_fleet_fit):
    err = _one_line_error(capsys, ["fit-fleet", table, "--out", str(tmp_path)])
    assert "--out: expected a file name, got the existing folder" in err


def test_fit_fleet_default_out_is_checked_too(capsys, tmp_path, table, no_fleet_fit):
    (tmp_path / "fleet.fleet.nc").mkdir()
    err = _one_line_error(capsys, ["fit-fleet", table])
    assert "fleet.fleet.nc" in err and "existing folder" in err


def test_out_under_a_file(capsys, tmp_path, table, no_fleet_fit):
    err = _one_line_error(capsys, ["fit-fleet", table, "--out", f"{table}/sub/fit.nc"])
    assert "expected a path under a folder" in err and "is a file" in err


@pytest.mark.skipif(os.geteuid() == 0, reason="root writes into any folder")
def test_out_in_an_unwritable_folder(capsys, tmp_path, table, no_fleet_fit):
    locked = tmp_path / "locked"
    locked.mkdir(mode=0o500)
    err = _one_line_error(capsys, ["fit-fleet", table, "--out", str(locked / "new" / "fit.nc")])
    assert "not writable" in err


def test_fit_tyre_checks_out_before_reading_the_stream(capsys, tmp_path):
    # The stream does not exist either: the --out message proves the order.
    argv = ["fit-tyre", str(tmp_path / "missing.csv"), "--vehicle", "compact_fwd"]
    err = _one_line_error(capsys, [*argv, "--out", str(tmp_path)])
    assert "fit-tyre: --out: expected a file name" in err
    err = _one_line_error(capsys, [*argv, "--out", str(tmp_path / "fit.txt")])
    assert "expected a file name ending in ['.nc', '.netcdf']" in err


@pytest.mark.parametrize("command", ["report", "demo"])
def test_folder_outputs(capsys, tmp_path, command):
    afile = tmp_path / "a.txt"
    afile.write_text("")
    args = [command, "--out"] if command == "demo" else [command, "x.nc", "--out"]
    assert "expected a folder, got the file" in _one_line_error(capsys, [*args, str(afile)])
    err = _one_line_error(capsys, [*args, str(afile / "sub")])
    assert "expected a path under a folder" in err


def test_an_os_error_on_a_named_file_is_one_line(capsys, monkeypatch):
    def disk_full(args):
        raise OSError(28, "No space left on device", "/data/fit.nc")

    monkeypatch.setattr(wear, "run_thesis", disk_full)
    err = _one_line_error(capsys, ["wear-thesis"])
    assert "'/data/fit.nc' (No space left on device)" in err


def test_an_os_error_without_a_file_keeps_its_traceback(monkeypatch):
    def bug(args):
        raise OSError("something internal")

    monkeypatch.setattr(wear, "run_thesis", bug)
    with pytest.raises(OSError, match="something internal"):
        main(["wear-thesis"])


# --- input paths that are not what they seem ---------------------------------------------------


def _inspect_error(capsys, path) -> str:
    return _one_line_error(capsys, ["inspect", str(path), "--vehicle", "compact_fwd"])


def test_a_folder_a_device_and_links_say_what_they_are(capsys, tmp_path):
    assert "got the folder" in _inspect_error(capsys, tmp_path)
    assert "not a regular file" in _inspect_error(capsys, "/dev/null")
    loop = tmp_path / "loop.csv"
    loop.symlink_to(loop)
    assert "symbolic links" in _inspect_error(capsys, loop)
    broken = tmp_path / "broken.csv"
    broken.symlink_to(tmp_path / "gone.csv")
    assert "broken link" in _inspect_error(capsys, broken)
    assert "file not found" in _inspect_error(capsys, tmp_path / "gone.csv")


def test_binary_files_named_csv_are_named_not_echoed(capsys, tmp_path):
    df = synthetic_stream(load_vehicle("compact_fwd"), duration_s=5.0)[0]
    parquet = tmp_path / "drive.csv"
    df.to_parquet(parquet)
    err = _inspect_error(capsys, parquet)
    assert "expected CSV text, got a Parquet file (rename it to .parquet)" in err
    junk = tmp_path / "junk.csv"
    junk.write_bytes(bytes(range(256)) * 8)
    assert "expected CSV text, got binary data" in _inspect_error(capsys, junk)
    mangled = tmp_path / "mangled.csv"
    mangled.write_bytes(b"time,a\n1,2\n" + bytes(range(1, 32)) + b"\xff\xfe,1,2,3\n")
    err = _inspect_error(capsys, mangled)
    assert "cannot parse" in err and err.rstrip("\n").isprintable()


def test_a_table_given_as_a_fit_says_so(capsys, tmp_path, table):
    err = _one_line_error(capsys, ["predict", table, "--c-xr", "30", "--type", "winter"])
    assert "expected a fleet fit (netCDF from fit-fleet), got text (a CSV" in err
    parquet = tmp_path / "fleet.parquet"
    pd.read_csv(table).to_parquet(parquet)
    err = _one_line_error(capsys, ["report", str(parquet), "--out", str(tmp_path / "r")])
    assert "got a Parquet file" in err


# --- implausible arguments and vehicle files ---------------------------------------------------


def test_warn_mu_min_is_checked_before_the_fit_is_read(capsys, tmp_path):
    argv = ["warn", str(tmp_path / "missing.nc"), "--c-xr", "30", "--type", "winter"]
    err = _one_line_error(capsys, [*argv, "--mu-min", "-5"])
    assert "--mu-min: expected a friction coefficient in (0, 2), got -5" in err


@pytest.mark.parametrize(("ambient", "needle"), [("500", "got 500\n"), ("293", "kelvin")])
def test_predict_wear_ambient_outside_the_thermal_model(capsys, ambient, needle):
    argv = ["predict-wear", "--gamma", "1e-4", "--c-xr", "40", "--ambient", ambient]
    err = _one_line_error(capsys, argv)
    assert "--ambient: expected an air temperature in [-40, 60] °C" in err and needle in err


def test_fit_tyre_ambient_is_checked_before_the_stream(capsys, tmp_path):
    argv = ["fit-tyre", str(tmp_path / "missing.csv"), "--vehicle", "compact_fwd"]
    assert "--ambient" in _one_line_error(capsys, [*argv, "--ambient", "-80"])


def test_a_1700_tonne_vehicle_is_rejected(capsys, tmp_path):
    text = (models_dir() / "vehicles" / "compact_fwd.toml").read_text()
    heavy = tmp_path / "heavy.toml"
    heavy.write_text(text.replace("mass_kg = 1600.0", "mass_kg = 1.7e6"))
    assert heavy.read_text() != text
    stream = tmp_path / "drive.csv"
    write_stream(synthetic_stream(load_vehicle("compact_fwd"), duration_s=5.0)[0], stream)
    err = _one_line_error(capsys, ["inspect", str(stream), "--vehicle", str(heavy)])
    assert "mass_kg: expected a road car's value in [300, 10000], got 1700000.0" in err


@pytest.mark.parametrize("sd", ["1e300", "inf", "0", "-1", "90"])
def test_fit_fleet_c_xr_sd_is_range_checked_before_the_fit(capsys, tmp_path, no_fleet_fit, sd):
    # 1e300 ran the sampler into 2,000 divergences (exit 3) where c_xr itself is checked.
    table = tmp_path / "fleet.csv"
    table.write_text(
        f"tyre_id,tyre_type,c_xr,c_xr_sd,mu\na,winter,40,1.5,0.3\nb,winter,42,{sd},0.3\n"
    )
    err = _one_line_error(capsys, ["fit-fleet", str(table), "--out", str(tmp_path / "f.nc")])
    assert "c_xr_sd: expected a standard error in (0, c_xr]" in err and "data row 2" in err


def test_predict_c_xr_sd_above_the_stiffness_is_refused(capsys, tmp_path):
    argv = ["predict", str(tmp_path / "missing.nc"), "--c-xr", "30", "--type", "winter"]
    err = _one_line_error(capsys, [*argv, "--c-xr-sd", "1e300"])
    assert "--c-xr-sd: expected a standard error in [0, --c-xr] (30), got 1e+300" in err


# --- closed pipes and signals ------------------------------------------------------------------


def test_json_into_a_closed_pipe_is_quiet():
    code = "import sys; from tyrebayes.cli import main; sys.exit(main())"
    with subprocess.Popen(
        [sys.executable, "-c", code, "wear-thesis", "--json"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
    ) as proc:
        proc.stdout.close()  # the reader is gone before the first write, as with `| head -0`
        err = proc.stderr.read().decode()
        assert proc.wait(timeout=120) == 1
    assert err == ""


def test_sigterm_while_writing_leaves_no_temporary_file(tmp_path, monkeypatch, capsys):
    target = tmp_path / "out.csv"
    real_to_csv = pd.DataFrame.to_csv

    def write_then_terminate(self, path, **kwargs):
        real_to_csv(self, path, **kwargs)  # half-way: the temporary file exists
        assert list(tmp_path.glob(".out.csv.*.tmp*"))
        os.kill(os.getpid(), signal.SIGTERM)

    monkeypatch.setattr(pd.DataFrame, "to_csv", write_then_terminate)
    monkeypatch.setattr(
        wear, "run_thesis", lambda args: write_stream(pd.DataFrame({"time": [0.0]}), target)
    )
    before = signal.getsignal(signal.SIGTERM)
    assert main(["wear-thesis"]) == 128 + signal.SIGTERM
    assert capsys.readouterr().err == "tyrebayes wear-thesis: interrupted (SIGTERM)\n"
    assert list(tmp_path.iterdir()) == []
    assert signal.getsignal(signal.SIGTERM) is before


# --- --out into folders that do not exist yet --------------------------------------------------


@pytest.mark.parametrize(
    "argv",
    [
        ["convert", "x.log", "--out", "new/sub/s.parquet"],
        ["fit-tyre", "x.csv", "--vehicle", "compact_fwd", "--out", "new/sub/f.nc"],
        ["fit-fleet", "t.csv", "--out", "new/sub/f.nc"],
        ["fleet-run", "m.csv", "--out", "new/sub"],
    ],
)
def test_out_into_missing_folders_is_one_rule_and_said(capsys, argv):
    # Every command makes the folders of --out (issue 57: say so, or refuse as others do): the
    # check before the work accepts them, and the help says it.
    from tyrebayes._commands._common import output_file, output_folder

    target = argv[argv.index("--out") + 1]
    (output_folder if argv[0] == "fleet-run" else output_file)(target)
    with pytest.raises(SystemExit):
        main([argv[0], "--help"])
    options = " ".join(capsys.readouterr().out.split()).split(" --")
    assert "created" in [o for o in options if o.startswith("out OUT ")][-1]


def test_a_stream_written_into_missing_folders(tmp_path):
    target = tmp_path / "new" / "sub" / "s.csv"
    write_stream(pd.DataFrame({"time": [0.0]}), target)
    assert target.is_file() and (target.stat().st_mode & 0o777) == 0o666 & ~_umask()


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask
