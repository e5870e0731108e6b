"""Saves to numba's kernel cache are serialised between processes (engine.kernel_cache): a save
waits while another holds the index's lock, and what it saved loads back under its own key."""

import fcntl
import threading
import time

from numba.core.caching import IndexDataCacheFile

import millsim.engine  # noqa: F401  (installs the lock)
from millsim.engine.kernel_cache import lock_path


def test_a_save_waits_for_the_lock_and_each_key_loads_its_own_data(tmp_path):
    first = IndexDataCacheFile(str(tmp_path), "kernel", source_stamp=(1.0, 10))
    second = IndexDataCacheFile(str(tmp_path), "kernel", source_stamp=(1.0, 10))
    first.save("variant a", {"physics": "a"})
    with open(lock_path(second), "a") as held:
        fcntl.flock(held, fcntl.LOCK_EX)  # another process in the middle of its save
        saver = threading.Thread(target=second.save, args=("variant b", {"physics": "b"}))
        saver.start()
        time.sleep(0.3)
        assert saver.is_alive()  # waits instead of reading an index about to change
    saver.join(timeout=10)
    assert not saver.is_alive()
    reader = IndexDataCacheFile(str(tmp_path), "kernel", source_stamp=(1.0, 10))
    assert reader.load("variant a") == {"physics": "a"}
    assert reader.load("variant b") == {"physics": "b"}
