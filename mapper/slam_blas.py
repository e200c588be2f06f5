"""Limit the BLAS thread pools numpy and scipy use (best effort, no extra dependency).

The EKF's matrices (about 600 x 600 at most) are too small for threads to pay: on a shared
2-core machine a multithreaded OpenBLAS made a 600 x 600 rank-40 update 10-30 times slower than a
single thread. ``OPENBLAS_NUM_THREADS=1`` in the environment before numpy is imported does the
same; this helper does it afterwards through the bundled OpenBLAS libraries' own setter.
"""

from __future__ import annotations

import ctypes
import logging
from pathlib import Path

log = logging.getLogger(__name__)

_SETTERS = ("scipy_openblas_set_num_threads64_", "scipy_openblas_set_num_threads",
            "openblas_set_num_threads64_", "openblas_set_num_threads")


def limit_blas_threads(threads: int = 1) -> int:
    """Set every bundled OpenBLAS (numpy's and scipy's wheels) to ``threads`` threads.

    Returns how many libraries were set (0 when none was found: nothing changes).
    """
    import numpy
    import scipy

    count = 0
    for package in (numpy, scipy):
        libs = Path(str(package.__file__)).resolve().parent.parent / f"{package.__name__}.libs"
        for path in sorted(libs.glob("lib*openblas*.so*")):
            try:
                lib = ctypes.CDLL(str(path))
            except OSError:
                continue
            for name in _SETTERS:
                setter = getattr(lib, name, None)
                if setter is not None:
                    setter(ctypes.c_int(threads))
                    count += 1
                    break
    log.debug("BLAS threads limited to %d in %d libraries", threads, count)
    return count
