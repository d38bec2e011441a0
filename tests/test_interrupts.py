"""Signals as one exception (tyrebayes._interrupts): held while an output is written, raised again
when Python swallowed it, restored after the command."""

from __future__ import annotations

import gc
import os
import signal
import subprocess
import sys
import threading
import time

import pytest

from tyrebayes import _interrupts


def _signal_in(seconds: float, sig=signal.SIGINT) -> threading.Timer:
    timer = threading.Timer(seconds, os.kill, (os.getpid(), sig))
    timer.start()
    return timer


def test_a_signal_is_an_interruption_with_its_exit_status():
    before = {s: signal.getsignal(s) for s in _interrupts.SIGNALS}
    with _interrupts.signals_as_interruptions():
        with pytest.raises(_interrupts.Interrupted) as info:
            os.kill(os.getpid(), signal.SIGTERM)
            time.sleep(5.0)
        assert info.value.exit_status == 143 and isinstance(info.value, KeyboardInterrupt)
        assert _interrupts.pending() == signal.SIGTERM
    assert {s: signal.getsignal(s) for s in _interrupts.SIGNALS} == before
    assert _interrupts.pending() is None


def test_held_inside_deferred_and_raised_at_its_end():
    with _interrupts.signals_as_interruptions():
        finished = False
        with pytest.raises(_interrupts.Interrupted):
            with _interrupts.deferred():
                os.kill(os.getpid(), signal.SIGINT)
                time.sleep(0.2)  # not cut short
                finished = True
        assert finished


def test_blocked_keeps_the_signal_in_the_kernel_until_its_end():
    # Loading compiled code: the signal must reach no thread, not even a helper's started
    # inside the block (OpenBLAS's took it while jaxlib loaded, and the command crashed). In a
    # fresh process, as the command line uses it: a thread started before the block (this test
    # process has several) would still take the signal.
    code = """
import os, signal, threading, time
from tyrebayes import _interrupts
mask = lambda: signal.pthread_sigmask(signal.SIG_BLOCK, [])
masks = []
with _interrupts.signals_as_interruptions():
    try:
        with _interrupts.blocked():
            helper = threading.Thread(target=lambda: masks.append(mask()))
            helper.start()
            helper.join()
            os.kill(os.getpid(), signal.SIGINT)
            time.sleep(0.2)
            print("pending", signal.SIGINT in signal.sigpending(), _interrupts.pending())
    except _interrupts.Interrupted as err:
        print("raised", err.signum == signal.SIGINT)
print("helper blocks", {signal.SIGINT, signal.SIGTERM} <= masks[0])
print("unblocked after", signal.SIGINT not in mask())
"""
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert out.stdout.splitlines() == [
        "pending True None",
        "raised True",
        "helper blocks True",
        "unblocked after True",
    ], out.stderr


def test_one_raised_in_a_gc_callback_is_raised_again_without_a_word(capfd):
    # JAX registers a gc callback; a signal that lands in it is "Exception ignored in ...",
    # a traceback on stderr, and the command ran on to its end (online, SIGTERM).
    first = [True]

    def slow_callback(phase, info):
        if phase == "start" and first[0]:
            first[0] = False
            time.sleep(0.5)  # the signal arrives in here

    gc.callbacks.append(slow_callback)
    try:
        with _interrupts.signals_as_interruptions():
            _signal_in(0.1, signal.SIGTERM)
            start = time.monotonic()
            with pytest.raises(_interrupts.Interrupted):
                for _ in range(200):
                    gc.collect(0)
                    time.sleep(0.02)
            assert time.monotonic() - start < 2.0
    finally:
        gc.callbacks.remove(slow_callback)
    assert capfd.readouterr().err == ""


def test_three_signals_end_the_process_at_once():
    # A clean-up that hangs: the third Ctrl-C stops without it, with one line.
    code = (
        "import time\n"
        "from tyrebayes import _interrupts\n"
        "with _interrupts.signals_as_interruptions():\n"
        "    try:\n"
        "        print('ready', flush=True)  # inside: the signal may come as soon as it is read\n"
        "        time.sleep(60)\n"
        "    finally:\n"
        "        print('cleaning up', flush=True)\n"
        "        time.sleep(60)\n"
    )
    with subprocess.Popen(
        [sys.executable, "-c", code], stdout=subprocess.PIPE, stderr=subprocess.PIPE
    ) as proc:
        try:
            assert proc.stdout.readline() == b"ready\n"
            proc.send_signal(signal.SIGINT)
            assert proc.stdout.readline() == b"cleaning up\n", proc.communicate(timeout=30)
            for _ in range(2):
                time.sleep(0.2)
                proc.send_signal(signal.SIGINT)
            _, err = proc.communicate(timeout=30)
        finally:
            if proc.poll() is None:
                proc.kill()
    assert proc.returncode == 130
    assert err.decode() == "tyrebayes: interrupted again, stopping without clean-up\n"


def test_a_signal_while_python_exits_after_a_success_keeps_its_status():
    # The command finished (its outputs written); Python's exit then took seconds (JAX, dask),
    # and a signal in it printed a KeyboardInterrupt traceback or died of SIGTERM (rc -15).
    code = (
        "import sys, time\n"
        "from tyrebayes import _interrupts\n"
        "with _interrupts.signals_as_interruptions(until_exit=True):\n"
        "    _interrupts.set_exit_status(3)\n"
        "print('done', flush=True)\n"
        "time.sleep(60)  # a slow exit\n"
    )
    proc = subprocess.Popen(
        [sys.executable, "-c", code], stdout=subprocess.PIPE, stderr=subprocess.PIPE
    )
    assert proc.stdout.readline() == b"done\n"
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=30)
    assert proc.returncode == 3 and err == b""


def test_a_signal_while_a_compiled_module_loads_waits_until_it_is_whole():
    # Ctrl-C while JAX was being imported: raised inside jaxlib's initialisation (which imports
    # Python modules), it crashed the command (a segmentation fault, or std::terminate). The
    # signal must wait for the extension module to be whole. _decimal's initialisation imports
    # Python modules too; an audit hook signals from inside the first of them.
    code = (
        "import os, signal, sys, time\n"
        "from tyrebayes import _interrupts\n"
        "assert '_decimal' not in sys.modules\n"
        "state = {'inside': False, 'survived': None}\n"
        "def hook(event, args):\n"
        "    if event == 'import' and args[0] == '_decimal':\n"
        "        state['inside'] = True\n"
        "    elif event == 'import' and state['inside'] and state['survived'] is None:\n"
        "        state['survived'] = False\n"
        "        os.kill(os.getpid(), signal.SIGINT)\n"
        "        time.sleep(0.2)  # the signal is handled in here unless it is held\n"
        "        state['survived'] = True\n"
        "sys.addaudithook(hook)\n"
        "with _interrupts.signals_as_interruptions():\n"
        "    try:\n"
        "        import decimal\n"
        "    except _interrupts.Interrupted:\n"
        "        print('interrupted', state['survived'])\n"
        "print('finder removed:', _interrupts._extension_finder not in sys.meta_path)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert out.stdout == "interrupted True\nfinder removed: True\n", out.stderr
