"""Interrupt requests (Ctrl-C, SIGTERM) that survive being swallowed.

The command line's handler records the signal and raises KeyboardInterrupt at once. Code that
catches BaseException on the way (a library compiling a kernel when the signal lands) would lose
that exception and the run would go on; the scene driver therefore also asks ``check()``
between chunks, which raises again while a request is recorded.
"""

import signal

_requested = []


def request(signum, frame=None):
    """Signal handler: record the request, then interrupt what runs now."""
    _requested.append(signum)
    raise KeyboardInterrupt(signum)


def check():
    """Raise KeyboardInterrupt if an interrupt was requested and not yet acted on."""
    if _requested:
        raise KeyboardInterrupt(_requested[-1])


def install():
    """Route SIGINT and SIGTERM through :func:`request` (main thread only); returns the previous
    handlers for :func:`restore`."""
    _requested.clear()
    return {s: signal.signal(s, request) for s in (signal.SIGINT, signal.SIGTERM)}


def restore(previous):
    """Put the handlers of :func:`install` back and forget any request (the command has ended:
    later runs in the same process must not see it)."""
    for signum, handler in previous.items():
        signal.signal(signum, handler)
    _requested.clear()
