"""``lock_memory`` locks the process's pages in RAM when the system allows it (the kernel's
``VmLck`` says so), and ``unlock_memory`` undoes it; where it is refused it says False and locks
nothing. Run in a child process: a lock would otherwise stay on the test runner."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

CHILD = """
import re
from orchestrator.priority import lock_memory, unlock_memory

def locked_kib():
    text = open("/proc/self/status").read()
    return int(re.search(r"VmLck:\\s+(\\d+) kB", text).group(1))

ok = lock_memory("test")
during = locked_kib()
unlock_memory()
print(ok, during, locked_kib())
"""


@pytest.mark.skipif(not Path("/proc/self/status").exists(), reason="needs Linux's /proc")
def test_lock_memory_locks_what_it_says_and_unlock_undoes_it() -> None:
    out = subprocess.run([sys.executable, "-c", CHILD], cwd=ROOT, capture_output=True,
                         text=True, timeout=60, check=True).stdout.split()
    ok, during_kib, after_kib = out[0] == "True", int(out[1]), int(out[2])
    if ok:
        assert during_kib > 1000  # the interpreter alone: megabytes
    else:
        assert during_kib == 0
    assert after_kib == 0
