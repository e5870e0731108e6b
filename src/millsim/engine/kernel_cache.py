"""Safe sharing of numba's on-disk kernel cache between processes (test workers, pipeline jobs).

numba saves a compiled variant by reading the function's cache index, giving a new key the first
free data-file number, writing the index back and then the data file. Two processes that save
different variants of one function at once (the loop's kernels are closures: one qualified name,
many physics variants) can both pick number 1: the index of one then points at the data of the
other, and a later process loads a kernel of other physics without noticing. Seen as a cold-cache
test run on two workers where stirred-mill drives turned backwards and Newton's third law failed
in the lubrication pair test, while the same tests passed alone, warm and cold (2026-11-28).
Saving under an exclusive lock on a file beside the index makes the read-modify-write of index and
data one step; loading needs no lock, as every data file is written whole (numba writes a
temporary file and renames it) and a number, once given under the lock, is never reused.
"""

import fcntl

from numba.core.caching import IndexDataCacheFile

_LOCKED = "_millsim_locked"


def lock_path(cache_file):
    return cache_file._index_path + ".lock"


def lock_cache_writes():
    """Make every save of numba's cache take the index's lock (once per process)."""
    save = IndexDataCacheFile.save
    if getattr(save, _LOCKED, False):
        return

    def save_under_lock(self, key, data):
        try:
            lock = open(lock_path(self), "a")
        except OSError:  # a read-only cache: numba's own save fails the same way and warns
            return save(self, key, data)
        with lock:
            fcntl.flock(lock, fcntl.LOCK_EX)
            return save(self, key, data)  # closing the file releases the lock

    setattr(save_under_lock, _LOCKED, True)
    IndexDataCacheFile.save = save_under_lock

