"""Upper bounds on the sizes a case allocates, from the memory they need, checked before anything
is allocated.

Each count or grid parameter of a scene is refused when the bytes it needs (estimated from the
arrays the scene makes of it) exceed the memory the run may use: the smallest of this machine's
RAM, the memory limit of its control group (a container, a SLURM job's cgroup), the SLURM job's
allocation (``SLURM_MEM_PER_NODE``, or ``SLURM_MEM_PER_CPU`` times the CPUs on the node) and
``millsim run --max-memory`` (or the environment variable ``MILLSIM_MAX_MEMORY``). The refusal is
one line: the key, the memory it needs, the limit and where it comes from, and the largest value
allowed.
"""

import contextlib
import os
import re
from pathlib import Path

MAX_MEMORY_ENV = "MILLSIM_MAX_MEMORY"
_GIVEN = None  # (bytes, what) of --max-memory while a run is being set up

_UNITS = {"": 1, "B": 1, "K": 2**10, "M": 2**20, "G": 2**30, "T": 2**40}


def parse_size(text, key="--max-memory"):
    """Bytes of a size as SLURM and ``--mem`` write it: ``16G``, ``500M``, ``1.5GiB``, ``2048``
    (bytes); K, M, G, T are powers of 1024."""
    match = re.fullmatch(r"\s*(\d+(?:\.\d*)?)\s*([KMGT]?)(?:i?B)?\s*", str(text), re.IGNORECASE)
    if not match or float(match[1]) <= 0:
        raise ValueError(f"{key}: expected a positive size such as 16G, 500M or 1.5GiB, got "
                         f"{text!r}")
    return int(float(match[1]) * _UNITS[match[2].upper()])


@contextlib.contextmanager
def max_memory(text, key="--max-memory"):
    """The limit ``text`` (parse_size; None: none given) in force while the block runs."""
    global _GIVEN
    previous = _GIVEN
    _GIVEN = (parse_size(text, key), f"of {key}") if text is not None else None
    try:
        yield
    finally:
        _GIVEN = previous


def _cgroup_limit():
    """This process's cgroup memory limit in bytes (v2 or v1), or None."""
    try:
        lines = Path("/proc/self/cgroup").read_text().splitlines()
    except OSError:
        return None
    for line in lines:
        _, controllers, where = line.split(":", 2)
        if controllers == "":  # v2: memory.max of the process's group
            candidates = (Path("/sys/fs/cgroup") / where.lstrip("/") / "memory.max",)
        elif "memory" in controllers.split(","):
            v1 = Path("/sys/fs/cgroup/memory")
            # the group's own file, or the root's where the group is this namespace's root
            candidates = (v1 / where.lstrip("/") / "memory.limit_in_bytes",
                          v1 / "memory.limit_in_bytes")
        else:
            continue
        for path in candidates:
            with contextlib.suppress(OSError, ValueError):
                text = path.read_text().strip()
                return None if text == "max" else int(text)
    return None


def _slurm_limit():
    """(bytes, variable) of the SLURM job's memory on this node, or None (SLURM's M are MiB)."""
    env = os.environ
    with contextlib.suppress(ValueError):
        if env.get("SLURM_MEM_PER_NODE"):
            return parse_size(env["SLURM_MEM_PER_NODE"] + "M", "SLURM_MEM_PER_NODE"), \
                "SLURM_MEM_PER_NODE"
        if env.get("SLURM_MEM_PER_CPU"):
            cpus = int(env.get("SLURM_CPUS_ON_NODE") or env.get("SLURM_CPUS_PER_TASK") or 1)
            return cpus * parse_size(env["SLURM_MEM_PER_CPU"] + "M", "SLURM_MEM_PER_CPU"), \
                f"SLURM_MEM_PER_CPU x {cpus} CPUs"
    return None


def memory_limit():
    """(bytes, what) of the memory a run may use, ``what`` naming where the limit comes from
    ("of this machine", "of the SLURM job (SLURM_MEM_PER_NODE)", ...); None where nothing is
    known (no sysconf: Windows)."""
    limits = []
    with contextlib.suppress(ValueError, OSError, AttributeError):
        limits.append((os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE"), "of this machine"))
    cgroup = _cgroup_limit()
    if cgroup:
        limits.append((cgroup, "of this process's control group (container or job limit)"))
    slurm = _slurm_limit()
    if slurm:
        limits.append((slurm[0], f"of the SLURM job ({slurm[1]})"))
    if os.environ.get(MAX_MEMORY_ENV):
        limits.append((parse_size(os.environ[MAX_MEMORY_ENV], MAX_MEMORY_ENV),
                       f"of {MAX_MEMORY_ENV}"))
    if _GIVEN is not None:
        limits.append(_GIVEN)
    return min(limits, key=lambda limit: limit[0]) if limits else None


def check_memory(key, value, need, noun, detail, allowed=None):
    """Refuse, naming ``key``, a count ``value`` whose ``need(value)`` bytes exceed
    :func:`memory_limit`, with the largest count allowed (``need`` grows with the count; ``noun``
    names what it counts, ``detail`` how the bytes are counted; ``allowed(largest)`` says the
    largest in the key's own terms where the key is not the count itself, e.g. an interval)."""
    limit = memory_limit()
    if limit is None or need(value) <= limit[0]:
        return
    largest, above = 0, int(value)
    while above - largest > 1:  # bisection: need(largest) fits, need(above) does not
        mid = (largest + above) // 2
        largest, above = (mid, above) if need(mid) <= limit[0] else (largest, mid)
    raise ValueError(f"{key}: {value} {noun} need at least {need(value) / 1e9:.3g} GB of memory "
                     f"({detail}), more than the {limit[0] / 1e9:.3g} GB {limit[1]}; allowed "
                     + (allowed(largest) if allowed else f"up to {largest} {noun}"))


# bytes of one recorded value: a float object and its list slot while recording, then its array
RECORD_VALUE_BYTES = 40
