"""Compile seconds per compiled function of one `millsim run` (numba's compile events).

    NUMBA_CACHE_DIR=$(mktemp -d) PYTHONPATH=TREE/src \
        python bench/compile_time.py run SCENE --set k=v ...

Runs the command in this process with a listener on numba's ``numba:compile`` event and prints, to
stderr, the process's wall time and the compile CPU seconds (the compiling thread's, so that other
load on the machine does not count) of the 15 most expensive functions (nested: a function's time
includes the functions compiled while it was being compiled). With an empty kernel cache this is the
compile cost of the scene's loop variant; comparing two trees on the same command gives the "compile
time per variant" of docs/results/restructure.md.
"""

import collections
import sys
import time

from numba.core import event

SECONDS = collections.defaultdict(float)


class CompileTimer(event.Listener):
    def __init__(self):
        self.started = {}

    def on_start(self, ev):
        self.started[id(ev.data["dispatcher"]), str(ev.data["args"])] = time.thread_time()

    def on_end(self, ev):
        key = id(ev.data["dispatcher"]), str(ev.data["args"])
        elapsed = time.thread_time() - self.started.pop(key)
        SECONDS[ev.data["dispatcher"].py_func.__qualname__] += elapsed


def main(argv):
    event.register("numba:compile", CompileTimer())
    t0, c0 = time.perf_counter(), time.process_time()
    from millsim.cli import main as millsim

    try:
        return millsim(argv)
    finally:
        print(f"process {time.perf_counter() - t0:.1f} s wall, {time.process_time() - c0:.1f} s CPU",
              file=sys.stderr)
        for name, s in sorted(SECONDS.items(), key=lambda kv: -kv[1])[:15]:
            print(f"{s:8.2f} s  {name}", file=sys.stderr)


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
