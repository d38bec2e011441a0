"""Interruptions (SIGINT, SIGTERM) as one exception, raised where it is safe to stop.

The command line (:func:`tyrebayes.cli.main`) turns both signals into :class:`Interrupted`, a
:class:`KeyboardInterrupt`, so that every ``finally`` block runs (temporary files removed, a dask
cluster closed) and the command ends with exit status 128 + the signal's number (130, 143) and one
line. Three rules keep an interruption from doing harm on its way out:

* **Outputs are all or nothing.** Inside :func:`deferred` (an output file being written and moved
  into place) a signal is held, not raised, so that no C library (HDF5, Arrow) is stopped half-way
  through a file; the writer then drops its temporary file instead of replacing the previous
  output (:func:`tyrebayes._io.atomic_output`).
* **An interruption is never swallowed.** Python drops an exception raised in a ``__del__`` or
  a gc callback (JAX has one: ``online`` once printed "Exception ignored in _xla_gc_callback"
  and ran to its end); such a one is raised again 20 ms later (and later again if it lands in
  such a place again), silently. Code that catches
  :class:`BaseException` drops it for good, so the signal is also recorded (:func:`pending`),
  and :func:`check` raises it at the next safe point: before an output replaces the previous
  one, and before a command returns success.
* **A compiled module is never cut half-way through its loading.** A C extension's
  initialisation can run Python code (its own imports); a signal raised there unwinds through C++
  that does not expect it (jaxlib's: a segmentation fault or ``std::terminate`` when Ctrl-C came
  while JAX was being imported). The command line loads its modules inside :func:`blocked`,
  and while it runs every extension module is created and executed inside it too
  (:class:`_HeldExtensionLoader`): the signal is raised just after the module is whole.
* **An interruption is not a failure.** Code that records failures as data (a fleet run's items)
  asks :func:`pending` before it records one: an item stopped by the interruption is left without
  a record and is run again next time.

Outside the command line nothing is installed: a program that imports the library keeps its own
signal handlers, and :func:`deferred` and :func:`check` then do nothing but their bookkeeping.

Examples
--------
>>> with deferred():
...     pass  # write and rename an output; a signal here is raised after the block
>>> pending() is None
True
"""

from __future__ import annotations

import _thread
import contextlib
import importlib.abc
import importlib.machinery
import os
import signal
import sys
import threading
from collections.abc import Callable, Iterator

#: The signals a command ends on, cleanly.
SIGNALS: tuple[int, ...] = (signal.SIGINT, signal.SIGTERM)

_pending: int | None = None  # the first signal's number
_signals = 0  # signals received
_armed = False  # the next handler call raises (again, after one was swallowed)
_redelivering = False
_redeliveries = 0
_timer: threading.Timer | None = None
_defer_depth = 0
_on_first: list[Callable[[], None]] = []


class Interrupted(KeyboardInterrupt):
    """The command was stopped by a signal (SIGINT, SIGTERM): not a failure of its work.

    Attributes
    ----------
    signum : int
        The signal's number; the command's exit status is ``128 + signum``.
    """

    def __init__(self, signum: int):
        super().__init__(signal.Signals(signum).name)
        self.signum = int(signum)

    @property
    def exit_status(self) -> int:
        return 128 + self.signum


def pending() -> int | None:
    """The number of the signal that interrupted this process, or None."""
    return _pending


def check() -> None:
    """Raise :class:`Interrupted` if a signal came (and was held or swallowed) since the start."""
    global _armed
    if _pending is not None and _defer_depth == 0:
        _armed = False
        raise Interrupted(_pending)


@contextlib.contextmanager
def deferred() -> Iterator[None]:
    """Hold SIGINT and SIGTERM for the block; a held one is raised when the block ends.

    For short sections that must not be cut: writing an output file and moving it into place.
    Nested blocks raise at the end of the outermost. Off the main thread, where no signal
    handler runs, the block only ends with :func:`check`.
    """
    global _defer_depth
    if threading.current_thread() is not threading.main_thread():
        yield
        check()
        return
    _defer_depth += 1
    try:
        yield
    finally:
        _defer_depth -= 1
    check()


@contextlib.contextmanager
def blocked() -> Iterator[None]:
    """Block SIGINT and SIGTERM in the operating system for the block; one that came is raised
    when it ends (as :func:`deferred` does).

    For loading compiled code, where a signal must not arrive at all: held in Python alone, it
    still reached jaxlib's initialisation (now and then a segmentation fault when Ctrl-C came
    while JAX loaded), by way of a helper thread (OpenBLAS's) that took the signal. Threads
    started inside the block inherit the mask and never take one; the main thread gets it when
    the block ends. Off the main thread nothing is done: no handler runs there, and raising in
    a helper thread's import would only break that thread.
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    with deferred():
        previous = signal.pthread_sigmask(signal.SIG_BLOCK, SIGNALS)
        try:
            yield
        finally:
            signal.pthread_sigmask(signal.SIG_SETMASK, previous)


def on_interrupt(callback: Callable[[], None]) -> None:
    """Call ``callback`` (quickly, without raising) when the first signal arrives.

    For quieting what would otherwise print during the way out (a cluster's closing logs).
    """
    _on_first.append(callback)


def _handler(signum: int, frame) -> None:
    global _pending, _signals, _armed, _redelivering
    if _redelivering:
        _redelivering = False  # a swallowed one, raised again (_unraisable)
    else:
        _signals += 1
        if _pending is None:
            _pending = signum
            for callback in _on_first:
                with contextlib.suppress(Exception):
                    callback()
        if _signals >= 3:
            # Two signals more while the first one's clean-up runs: the user wants out now.
            os.write(2, b"tyrebayes: interrupted again, stopping without clean-up\n")
            os._exit(128 + _pending)
    if _armed and _defer_depth == 0:
        _armed = False
        raise Interrupted(_pending)
    # A signal while the first is being handled, or inside deferred(): held.


def _unraisable(unraisable) -> None:
    """Python dropped an :class:`Interrupted` (raised in a gc callback or a ``__del__``, where
    an exception cannot propagate): raise it again shortly, from wherever the command is then,
    instead of printing "Exception ignored in ..." with a traceback and running on."""
    global _armed, _redeliveries, _timer
    if not isinstance(unraisable.exc_value, Interrupted):
        _previous_hook(unraisable)
        return
    # Soon, and later each time it lands in such a place again (a run of collections).
    delay = min(0.02 * 2**_redeliveries, 0.5)
    _redeliveries += 1
    _armed = True
    _timer = threading.Timer(delay, _redeliver)
    _timer.daemon = True
    _timer.start()


def _redeliver() -> None:
    global _redelivering
    if _active and _armed and _pending is not None:
        _redelivering = True
        _thread.interrupt_main(_pending)


_active = False
_previous_hook = sys.unraisablehook


class _HeldExtensionLoader(importlib.machinery.ExtensionFileLoader):
    """An extension module's loader whose creation and execution block signals (:func:`blocked`)."""

    def create_module(self, spec):
        with blocked():
            return super().create_module(spec)

    def exec_module(self, module) -> None:
        with blocked():
            super().exec_module(module)


class _HoldExtensionLoading(importlib.abc.MetaPathFinder):
    """First on ``sys.meta_path``: asks the finders after it, and hands a C extension's spec
    a :class:`_HeldExtensionLoader` in place of the plain one."""

    def find_spec(self, fullname, path, target=None):
        for finder in sys.meta_path:
            find = getattr(finder, "find_spec", None)
            if finder is self or find is None:
                continue
            spec = find(fullname, path, target)
            if spec is not None:
                break
        else:
            return None
        loader = spec.loader
        if type(loader) is importlib.machinery.ExtensionFileLoader:
            spec.loader = _HeldExtensionLoader(loader.name, loader.path)
        return spec


_extension_finder = _HoldExtensionLoading()


_exit_status = 1  # what a signal after the block ends the process with (until_exit)


def set_exit_status(status: int) -> None:
    """The status the command ended with, for a signal that comes while Python exits."""
    global _exit_status
    _exit_status = int(status)


def _late_handler(signum: int, frame) -> None:
    # The command is done and its outputs are written; Python is exiting (JAX's and dask's
    # teardown can take seconds). Stop now, with the command's own status: a default handler
    # here printed a KeyboardInterrupt traceback or died of SIGTERM after a success.
    for stream in (sys.stdout, sys.stderr):
        with contextlib.suppress(Exception):
            stream.flush()
    os._exit(_exit_status)


@contextlib.contextmanager
def signals_as_interruptions(*, until_exit: bool = False) -> Iterator[None]:
    """Within the block, SIGINT and SIGTERM raise :class:`Interrupted` (main thread only).

    The previous handlers and the pending state are restored after it, so that a test or a
    program that calls :func:`tyrebayes.cli.main` twice starts each call afresh. With
    ``until_exit`` (the process is the command's) a signal after the block ends the process at
    once with the status given to :func:`set_exit_status`.
    """
    global _pending, _signals, _armed, _redelivering, _redeliveries, _active, _previous_hook
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = {s: signal.getsignal(s) for s in SIGNALS}
    _pending, _signals, _armed, _redelivering, _redeliveries = None, 0, True, False, 0
    _previous_hook, sys.unraisablehook = sys.unraisablehook, _unraisable
    _active = True
    sys.meta_path.insert(0, _extension_finder)
    for s in SIGNALS:
        signal.signal(s, _handler)
    try:
        yield
    finally:
        _active = False
        with contextlib.suppress(ValueError):
            sys.meta_path.remove(_extension_finder)
        if _timer is not None:
            _timer.cancel()
        for s, handler in previous.items():
            # None: the previous handler was not set from Python; restore the default then.
            restored = signal.SIG_DFL if handler is None else handler
            signal.signal(s, _late_handler if until_exit else restored)
        sys.unraisablehook = _previous_hook
        _pending, _signals, _armed = None, 0, False
        _on_first.clear()


def ignore_in_child() -> None:
    """Ignore SIGINT in this (worker) process: Ctrl-C reaches a terminal's whole process group,
    and a fleet run's local workers are stopped by their client, not by the key."""
    if threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGINT, signal.SIG_IGN)
