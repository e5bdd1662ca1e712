"""Normal equations of a least-squares problem, solved while they are well-posed.

A fit's bases are tall and narrow: ``A^T A`` and ``A^T y`` are cheap, and solving them by
Cholesky is faster than any factorisation of ``A``. They lose the square of ``A``'s
condition number, so they are solved only while LAPACK's estimate of their reciprocal
condition number (1-norm) stays above :data:`WELL_POSED`; below it the caller solves on the
rows (a rank-revealing solver).
"""

from __future__ import annotations

import numpy as np
from scipy.linalg import lapack

__all__ = ["WELL_POSED", "normal_solution"]

#: Reciprocal condition number of the normal equations (columns scaled to unit norm) above
#: which :func:`normal_solution` solves them.
WELL_POSED = 1e-8


def normal_solution(gram: np.ndarray, rhs: np.ndarray) -> np.ndarray | None:
    """The solution of ``gram @ x = rhs`` (a symmetric, positive definite ``gram``) by
    Cholesky; None when ``gram`` is not positive definite or its reciprocal condition number
    is :data:`WELL_POSED` or below (also when it holds NaN)."""
    factor, info = lapack.dpotrf(gram)
    if info != 0 or not lapack.dpocon(factor, np.abs(gram).sum(axis=0).max())[0] > WELL_POSED:
        return None
    return lapack.dpotrs(factor, rhs)[0]
