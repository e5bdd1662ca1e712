"""Ctrl-C and SIGTERM held back while a step runs that an exception would leave half done."""

import signal
import threading
from contextlib import contextmanager

__all__ = ["interrupts_held"]


@contextmanager
def interrupts_held():
    """Keep Ctrl-C (SIGINT) and SIGTERM while the block runs, and take them at its end, as if
    they came then.

    A process pool interrupted while it starts its processes has some started and no thread
    yet to stop them: its shutdown returns, and the interpreter's exit waits for them forever.
    In a thread other than the main one (where Python runs no signal handler) the block runs
    as it is.
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    caught: list[int] = []
    previous = {}
    for signum in (signal.SIGINT, signal.SIGTERM):
        handler = signal.getsignal(signum)
        if callable(handler):  # (one not set from Python, or ignored, or the default, is kept)
            previous[signum] = signal.signal(signum, lambda s, frame: caught.append(s))
    try:
        yield
    finally:
        for signum, handler in previous.items():
            signal.signal(signum, handler)
        for signum in dict.fromkeys(caught):
            signal.raise_signal(signum)
