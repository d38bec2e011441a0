"""Ctrl-C and SIGTERM end every command cleanly (issue 57).

Each command runs in a child process, as a user runs it (``main()`` reading ``sys.argv``). A hook
wrapped around the step the command is busy in (decoding a CAN log, a fit, the online filter,
writing ``--out``) creates a marker file when the step starts; the test then sends a real signal
and checks what the user sees: exit status 130 (SIGINT) or 143 (SIGTERM), exactly one line on
stderr and no traceback, the previous ``--out`` as it was, no temporary file, and no crash on the
way out (``online`` segfaulted on Ctrl-C before). After the real step the hook sleeps, so that the
signal always arrives before the command could finish on its own.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from tyrebayes._domain import load_vehicle
from tyrebayes.simulate.can_log import stream_messages, write_can_log
from tyrebayes.streams import write_stream
from tyrebayes.streams.can import load_dbc, load_profile
from tyrebayes.streams.synthetic import synthetic_stream

OLD = b"the previous output"

# The child: wrap MODULE.NAME so that it announces itself in the marker file, runs, and then
# sleeps (or, with SWALLOW, signals itself and swallows the interruption); then run the command.
_CHILD = """
import importlib, os, signal, sys, time
module_name, name, marker, mode = sys.argv[1:5]
sys.argv = ["tyrebayes", *sys.argv[5:]]
if "." in name:  # a method: Class.method
    owner_name, name = name.split(".")
    owner = getattr(importlib.import_module(module_name), owner_name)
else:
    owner = importlib.import_module(module_name)
real = getattr(owner, name)

def hooked(*args, **kwargs):
    open(marker, "w").close()
    if mode == "write":  # the signal comes while --out is being written
        result = real(*args, **kwargs)
        time.sleep(3.0)
        return result
    if mode == "swallow":  # code on the way swallows the interruption
        result = real(*args, **kwargs)
        try:
            os.kill(os.getpid(), signal.SIGINT)
            time.sleep(1.0)
        except BaseException:
            pass
        return result
    result = real(*args, **kwargs)
    time.sleep(120.0)
    return result

setattr(owner, name, hooked)
from tyrebayes.cli import main
sys.exit(main())
"""


def _run_and_signal(
    tmp_path: Path, hook: str, argv: list[str], sig=signal.SIGINT, mode: str = "busy"
) -> tuple[int, str, float]:
    """Run the command with the hook; send ``sig`` once the hooked step started (not with
    ``mode="swallow"``, where the child signals itself). Returns (status, stderr, seconds from
    the signal to the exit)."""
    module, name = hook.rsplit(":", 1)
    marker = tmp_path / "busy.marker"
    # faulthandler: a crash on the way out shows where it happened, not only "-11"
    env = {**os.environ, "JAX_PLATFORMS": "cpu", "PYTHONFAULTHANDLER": "1"}
    proc = subprocess.Popen(
        [sys.executable, "-c", _CHILD, module, name, str(marker), mode, *argv],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        cwd=tmp_path,
        env=env,
    )
    try:
        deadline = time.monotonic() + 240.0
        while not marker.exists() and proc.poll() is None and time.monotonic() < deadline:
            time.sleep(0.05)
        assert marker.exists(), proc.stderr.read().decode() if proc.poll() is not None else ""
        sent = time.monotonic()
        if mode != "swallow":
            time.sleep(0.3)  # into the step, past the hook's first line
            proc.send_signal(sig)
        # generous: under a loaded machine the hooked step itself (a decode) can take minutes
        _, err = proc.communicate(timeout=300)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    return proc.returncode, err.decode(), time.monotonic() - sent


def _assert_clean(status, err, command, sig=signal.SIGINT):
    assert status == 128 + sig, err
    assert err == f"tyrebayes {command}: interrupted ({signal.Signals(sig).name})\n", err
    assert "Traceback" not in err


def _no_temporaries(folder: Path) -> None:
    assert not [p.name for p in folder.rglob(".*.tmp*")], "temporary files left behind"


@pytest.fixture(scope="module")
def can_log(tmp_path_factory):
    rav4 = load_vehicle("suv_rav4")
    profile = load_profile("toyota_rav4_2017")
    df, _ = synthetic_stream(rav4, duration_s=8.0, rate_hz=50.0, seed=3)
    messages = stream_messages(
        df, profile, load_dbc(profile.dbc_path()), wheel_radius_m=rav4.wheel_radius_m
    )
    return write_can_log(messages, tmp_path_factory.mktemp("can") / "drive.log")


@pytest.fixture(scope="module")
def stream(tmp_path_factory):
    df, _ = synthetic_stream(load_vehicle("compact_fwd"), duration_s=120.0, rate_hz=10.0, seed=1)
    path = tmp_path_factory.mktemp("stream") / "drive.parquet"
    write_stream(df, path)
    return path


def _convert_argv(can_log, out):
    return ["convert", str(can_log), "--profile", "toyota_rav4_2017", "--out", str(out)]


def test_ctrl_c_while_convert_decodes(tmp_path, can_log):
    out = tmp_path / "stream.parquet"
    out.write_bytes(OLD)
    status, err, _ = _run_and_signal(
        tmp_path, "tyrebayes.streams.can:read_can_log", _convert_argv(can_log, out)
    )
    _assert_clean(status, err, "convert")
    assert out.read_bytes() == OLD
    _no_temporaries(tmp_path)


def test_ctrl_c_while_out_is_written_keeps_the_previous_out(tmp_path, can_log):
    # The signal comes while the new stream file is half-way: it is written to the end (no
    # library is stopped inside a file), then dropped; the previous one stays.
    out = tmp_path / "stream.parquet"
    out.write_bytes(OLD)
    status, err, after = _run_and_signal(
        tmp_path, "pandas:DataFrame.to_parquet", _convert_argv(can_log, out), mode="write"
    )
    _assert_clean(status, err, "convert")
    assert out.read_bytes() == OLD
    _no_temporaries(tmp_path)
    assert after < 30.0  # no hang in the write


def test_an_interruption_swallowed_on_the_way_is_not_a_success(tmp_path, can_log):
    # Python drops an exception raised where it cannot propagate (a __del__, a callback, an
    # ``except BaseException``): the command must not go on to replace --out and exit 0.
    out = tmp_path / "stream.parquet"
    out.write_bytes(OLD)
    status, err, _ = _run_and_signal(
        tmp_path, "tyrebayes.streams.can:read_can_log", _convert_argv(can_log, out), mode="swallow"
    )
    _assert_clean(status, err, "convert")
    assert out.read_bytes() == OLD
    _no_temporaries(tmp_path)


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
def test_signal_while_fit_tyre_fits(tmp_path, stream, sig):
    out = tmp_path / "fit.nc"
    out.write_bytes(OLD)
    argv = ["fit-tyre", str(stream), "--vehicle", "compact_fwd", "--method", "fast"]
    argv += ["--model", "linear", "--out", str(out)]
    status, err, after = _run_and_signal(
        tmp_path, "tyrebayes.inference.tyre.fit:fit_tyre", argv, sig=sig
    )
    _assert_clean(status, err, "fit-tyre", sig)
    assert out.read_bytes() == OLD
    _no_temporaries(tmp_path)
    assert after < 60.0


def test_ctrl_c_in_online_does_not_crash(tmp_path, stream):
    argv = ["online", str(stream), "--vehicle", "compact_fwd", "--model", "linear"]
    status, err, _ = _run_and_signal(tmp_path, "tyrebayes.inference.online:online_estimate", argv)
    _assert_clean(status, err, "online")  # was a traceback, then exit 139 (segfault)


def test_ctrl_c_while_the_commands_load(tmp_path, stream):
    # The signal comes while the command modules (and JAX with them) are being imported:
    # ``import tyrebayes`` loads nothing heavy, so the handler is already in place. One that
    # lands inside jaxlib's own initialisation waits until it is whole (it crashed there).
    argv = ["fit-tyre", str(stream), "--vehicle", "compact_fwd"]
    status, err, _ = _run_and_signal(tmp_path, "tyrebayes.cli:build_parser", argv)
    assert status == 130, err
    assert err == "tyrebayes: interrupted (SIGINT)\n", err
