"""One BLAS thread while a fit runs (creepcomp.fit.blas)."""

import pytest
from threadpoolctl import ThreadpoolController

from creepcomp.fit.blas import one_blas_thread


def blas_counts():
    return {p["num_threads"] for p in ThreadpoolController().info() if p["user_api"] == "blas"}


def test_one_thread_inside_and_the_count_restored_after():
    import scipy.linalg  # noqa: F401

    if not blas_counts():
        pytest.skip("no BLAS library that threadpoolctl controls here")
    with ThreadpoolController().limit(limits=2, user_api="blas"):
        with one_blas_thread():
            assert blas_counts() == {1}
            with one_blas_thread():
                assert blas_counts() == {1}
            assert blas_counts() == {1}
        assert blas_counts() == {2}

