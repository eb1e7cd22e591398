"""SIGINT / SIGTERM as an orderly stop: one line, exit 130 / 143, nothing left running.

Inside ``with interruptible():`` (main thread only; elsewhere it does
nothing) both signals raise :class:`Interrupted`, a ``BaseException`` (so
``except Exception`` in library code does not swallow it), and unwinding
runs every ``finally``: process pools terminate their workers, run folders
write ``run.json`` with ``complete: false`` (:mod:`knitfem.io.run`), atomic
writes drop their temporaries.  A second signal during that clean-up ends the
process at once.

A signal can arrive while compiled code (numba) is returning; Python then
raises a ``SystemError`` chained to the interruption instead of the
interruption itself.  :func:`interruption` maps any exception raised after a
signal back to the :class:`Interrupted` that caused it, so callers write::

    with interruptible():
        try:
            work()
        except BaseException as err:
            stop = interruption(err)
            if stop is None:
                raise
            print(f"knitfem: interrupted ({stop.signal_name})", file=sys.stderr)
            return stop.exit_code          # 130 (SIGINT) or 143 (SIGTERM)

Worker processes call :func:`worker_signals` first: they ignore SIGINT (a
Ctrl-C reaches the whole process group; the parent decides) and exit when
their parent has gone (a parent killed by SIGKILL cannot clean up).
"""
from contextlib import contextmanager
import os
import signal
import threading
import time

SIGNALS = (signal.SIGINT, signal.SIGTERM)
_received = []


class Interrupted(BaseException):
    """Raised in the main thread by SIGINT or SIGTERM."""

    def __init__(self, signum):
        self.signum = int(signum)
        self.signal_name = signal.Signals(self.signum).name
        super().__init__(f"interrupted by {self.signal_name}")

    def __reduce__(self):
        return (type(self), (self.signum,))

    @property
    def exit_code(self):
        """128 + the signal number: 130 for SIGINT, 143 for SIGTERM."""
        return 128 + self.signum


def _handler(signum, frame):
    if _received:                       # the second signal: no more clean-up
        os._exit(128 + signum)
    _received.append(signum)
    raise Interrupted(signum)


@contextmanager
def interruptible():
    """Turn SIGINT and SIGTERM into :class:`Interrupted` inside the block."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = {s: signal.signal(s, _handler) for s in SIGNALS}
    _received.clear()
    try:
        yield
    finally:
        for s, h in previous.items():
            signal.signal(s, h)
        _received.clear()


def interruption(error):
    """The :class:`Interrupted` behind ``error`` (itself, a chained cause or
    context, or a signal received while it was raised), else None."""
    seen = error
    while seen is not None:
        if isinstance(seen, (Interrupted, KeyboardInterrupt)):
            return seen if isinstance(seen, Interrupted) else Interrupted(signal.SIGINT)
        seen = seen.__cause__ or seen.__context__
    if _received:
        return Interrupted(_received[0])
    return None


def _watch_parent(parent, period):
    while True:
        time.sleep(period)
        if os.getppid() != parent:
            os._exit(1)


def worker_signals(parent=None, period=1.0):
    """For a worker process: ignore SIGINT, default SIGTERM, and exit within
    ``period`` seconds once the parent ``parent`` (pid) is gone."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    if parent is not None:
        threading.Thread(target=_watch_parent, args=(parent, period), daemon=True).start()
