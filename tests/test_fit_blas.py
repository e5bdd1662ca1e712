"""One BLAS thread while a fit runs (creepcomp.fit.blas)."""

import threading

import pytest
from threadpoolctl import ThreadpoolController

from creepcomp.fit.blas import one_blas_thread


def blas_counts(controller):
    return [p["num_threads"] for p in controller.info() if p["user_api"] == "blas"]


def test_one_thread_inside_and_the_counts_restored_after_the_last_leaves():
    import scipy.linalg  # noqa: F401

    controller = ThreadpoolController()
    if not blas_counts(controller):
        pytest.skip("no BLAS library that threadpoolctl controls here")
    with controller.limit(limits=2, user_api="blas"):
        entered, leave = threading.Event(), threading.Event()

        def other():
            with one_blas_thread():
                entered.set()
                leave.wait(5)

        worker = threading.Thread(target=other)
        worker.start()
        entered.wait(5)
        with one_blas_thread():
            assert set(blas_counts(ThreadpoolController())) == {1}
        assert set(blas_counts(ThreadpoolController())) == {1}     # the other thread still fits
        leave.set()
        worker.join()
        assert set(blas_counts(ThreadpoolController())) == {2}
