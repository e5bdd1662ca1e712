"""One BLAS thread while a fit runs (creepcomp.fit.blas)."""

import threading

import pytest

from creepcomp.fit.blas import blas_thread_setters, one_blas_thread


def counts(setters):
    """The current thread counts, read by setting them to what they are."""
    out = []
    for setter in setters:
        count = setter(1)
        setter(count)
        out.append(count)
    return out


def test_one_thread_inside_and_the_counts_restored_after_the_last_leaves():
    with one_blas_thread():
        setters = blas_thread_setters()
    if not setters:
        pytest.skip("no OpenBLAS bundled with numpy or scipy here")
    original = [setter(2) for setter in setters]
    try:
        _check_two_threads_fitting(setters)
    finally:
        for setter, count in zip(setters, original):
            setter(count)


def _check_two_threads_fitting(setters):
    entered, leave = threading.Event(), threading.Event()

    def other():
        with one_blas_thread():
            entered.set()
            leave.wait(5)

    worker = threading.Thread(target=other)
    worker.start()
    entered.wait(5)
    with one_blas_thread():
        assert counts(setters) == [1] * len(setters)
    assert counts(setters) == [1] * len(setters)      # the other thread still fits
    leave.set()
    worker.join()
    assert counts(setters) == [2] * len(setters)
