"""Direct calls into the BLAS numpy bundles (best effort, no extra dependency).

- :func:`limit_blas_threads`: the EKF's matrices (about 600 x 600 at most) are too small for
  threads to pay: on a shared 2-core machine a multithreaded OpenBLAS made a 600 x 600 rank-40
  update 10-30 times slower than a single thread. ``OPENBLAS_NUM_THREADS=1`` in the environment
  before numpy is imported does the same; this helper does it afterwards through the bundled
  OpenBLAS libraries' own setter.
- :func:`syrk_lower_inplace`: ``C <- C + alpha V V^T`` on the lower triangle of a STRIDED view
  (a covariance stored in a larger buffer with spare capacity) through ``cblas_dsyrk``: half the
  multiply-adds of a full product and no (n, n) temporary. numpy's matmul and scipy's f2py
  wrappers cannot do this in place on a non-contiguous view (f2py silently copies it).
- :func:`mirror_lower`: copy the strict lower triangle onto the upper one (blocked).
"""

from __future__ import annotations

import ctypes
import logging
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

log = logging.getLogger(__name__)

FloatArray = NDArray[np.float64]

_SETTERS = ("scipy_openblas_set_num_threads64_", "scipy_openblas_set_num_threads",
            "openblas_set_num_threads64_", "openblas_set_num_threads")
_SYRK = (("scipy_cblas_dsyrk64_", ctypes.c_int64), ("cblas_dsyrk64_", ctypes.c_int64),
         ("scipy_cblas_dsyrk", ctypes.c_int32), ("cblas_dsyrk", ctypes.c_int32))
"""cblas_dsyrk symbols of the OpenBLAS builds numpy wheels bundle: ILP64 (``64_`` suffix,
64-bit sizes) or LP64; the enum arguments are C ints either way."""
_ROW_MAJOR, _LOWER, _TRANS = 101, 122, 112
_MIRROR_BLOCK = 64
"""Block size of :func:`mirror_lower` (a 64 x 64 tile of doubles is 32 kB, in L1/L2)."""


def _openblas_libraries(*packages: Any) -> list[Path]:
    paths: list[Path] = []
    for package in packages:
        libs = Path(str(package.__file__)).resolve().parent.parent / f"{package.__name__}.libs"
        paths.extend(sorted(libs.glob("lib*openblas*.so*")))
    return paths


def limit_blas_threads(threads: int = 1) -> int:
    """Set every bundled OpenBLAS (numpy's and scipy's wheels) to ``threads`` threads.

    Returns how many libraries were set (0 when none was found: nothing changes).
    """
    import scipy

    count = 0
    for path in _openblas_libraries(np, scipy):
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


def _load_syrk() -> Any:
    """numpy's bundled ``cblas_dsyrk`` with its argument types, or None."""
    for path in _openblas_libraries(np):
        try:
            lib = ctypes.CDLL(str(path))
        except OSError:
            continue
        for name, blasint in _SYRK:
            fn = getattr(lib, name, None)
            if fn is None:
                continue
            c_int, c_double, c_void_p = ctypes.c_int, ctypes.c_double, ctypes.c_void_p
            fn.argtypes = [c_int, c_int, c_int, blasint, blasint, c_double, c_void_p, blasint,
                           c_double, c_void_p, blasint]
            fn.restype = None
            log.debug("cblas dsyrk: %s in %s", name, path.name)
            return fn
    log.debug("no bundled cblas_dsyrk found: the numpy fallback is used")
    return None


_syrk_fn: Any = _load_syrk()


def have_syrk() -> bool:
    """Whether :func:`syrk_lower_inplace` reaches a BLAS (otherwise it returns False)."""
    return _syrk_fn is not None


def syrk_lower_inplace(c: FloatArray, v: FloatArray, alpha: float = -1.0) -> bool:
    """``C <- C + alpha V V^T`` on the lower triangle (``j <= i``) of ``c``, in place.

    ``c`` (n, n) float64 with unit column stride and any row stride (a view into a buffer with
    capacity); ``v`` (n, k) Fortran-ordered (as ``scipy.linalg.blas.dtrsm`` returns it; other
    layouts are copied). The strict upper triangle is NOT touched. Returns False (nothing done)
    when no BLAS was found or ``c`` has a layout BLAS cannot address; the caller falls back.
    """
    n = c.shape[0]
    if (_syrk_fn is None or c.ndim != 2 or c.shape[1] != n or c.dtype != np.float64
            or c.strides[1] != 8 or c.strides[0] % 8 or c.strides[0] < 8 * n
            or not c.flags.writeable or v.shape[0] != n):
        return False
    if n == 0:
        return True
    a = np.asfortranarray(v, np.float64).T                       # (k, n) C order, lda n
    k = a.shape[0]
    if k == 0:
        return True
    _syrk_fn(_ROW_MAJOR, _LOWER, _TRANS, n, k, alpha, a.ctypes.data, n, 1.0, c.ctypes.data,
             c.strides[0] // 8)
    return True


def mirror_lower(c: FloatArray, start: int = 0) -> None:
    """Copy the strict lower triangle of the square ``c`` onto its upper triangle, in place,
    for rows/columns ``start:`` (the rest is left alone). Exact: ``c`` ends symmetric there."""
    n = c.shape[0]
    b = _MIRROR_BLOCK
    for j0 in range(start, n, b):
        j1 = min(j0 + b, n)
        d = c[j0:j1, j0:j1]
        np.copyto(d, d.T.copy(), where=_upper_mask(j1 - j0))
        if j1 < n:
            c[j0:j1, j1:] = c[j1:, j0:j1].T


_masks: dict[int, NDArray[np.bool_]] = {}


def _upper_mask(m: int) -> NDArray[np.bool_]:
    mask = _masks.get(m)
    if mask is None:
        mask = _masks[m] = np.triu(np.ones((m, m), bool), 1)
    return mask
