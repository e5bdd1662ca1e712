"""Models of measured records, by job: the record prepared for fitting (:mod:`.data`), model
structures and their linear basis (:mod:`.structure`), the residual's AR noise and the
information criterion (:mod:`.noise`), the least-squares solver (:mod:`.solver`), held-out
evidence (:mod:`.evidence`), start values (:mod:`.starts`), Prony identification with the
number of terms chosen by evidence (:mod:`.prony`), the model of a built network's
measured output (:mod:`.circuit`, the circuit side of the diagnosis), and long records reduced
before fitting (:mod:`.reduce`).

The names below are imported from their modules when first used: a long record is read and
reduced (:mod:`.reduce`, numpy only) while another thread imports the solver's scipy.
"""

from importlib import import_module
from typing import TYPE_CHECKING

if TYPE_CHECKING:                   # (for type checkers and the API pages)
    from creepcomp.fit.circuit import CircuitData, CircuitFit
    from creepcomp.fit.data import CONSTANT_LOAD_TOLERANCE, GAP_FACTOR, Data, gaps, prepare
    from creepcomp.fit.evidence import (BIC_STRONG, BLOCK_MEMORY, BLOCKS, FOLDS, HELDOUT_Z,
        MIN_BLOCK_SAMPLES, SLOW_NOISE_RATIO, UNDETERMINED_VARIANCE_RATIO, Evidence, HeldOut, block_index,
        block_memory, compare,
        compare_with_halves, half_blocks, halves, heldout, jacobian, load_halves, predict_held_out,
        slow_noise_ratio)
    from creepcomp.fit.noise import (MAX_AR_ORDER, ARNoise, autocorrelation, fit_noise, gaussian_bic,
        ljung_box, rows_for, spectral_variance, whiten)
    from creepcomp.fit.prony import (FIT_MAX_TERMS, OrderStep, PronyResult, fit_prony, fit_record,
        fit_summary, fit_terms,
        model_file_dict, term_table)
    from creepcomp.fit.solver import ANCHOR_WEIGHT, Fit, Problem, best_of_starts, fit_structure, with_noise
    from creepcomp.fit.starts import cluster_taus, extra_term_starts, nnls_spectrum, one_term_starts, tau_grid
    from creepcomp.fit.structure import Applied, Basis, Param, Structure, basis, taus_of


__all__ = [
    "CircuitData", "CircuitFit",
    "CONSTANT_LOAD_TOLERANCE", "GAP_FACTOR", "Data", "gaps", "prepare",
    "BIC_STRONG", "BLOCK_MEMORY", "BLOCKS", "FOLDS", "HELDOUT_Z", "MIN_BLOCK_SAMPLES",
    "SLOW_NOISE_RATIO", "UNDETERMINED_VARIANCE_RATIO", "Evidence", "HeldOut", "block_index",
    "block_memory", "compare",
    "compare_with_halves", "half_blocks", "halves", "load_halves", "heldout", "jacobian", "predict_held_out",
    "slow_noise_ratio",
    "MAX_AR_ORDER", "ARNoise", "autocorrelation", "fit_noise", "gaussian_bic", "ljung_box",
    "rows_for", "spectral_variance", "whiten",
    "FIT_MAX_TERMS", "OrderStep", "PronyResult", "fit_prony", "fit_record", "fit_summary",
    "fit_terms", "model_file_dict",
    "term_table",
    "ANCHOR_WEIGHT", "Fit", "Problem", "best_of_starts", "fit_structure", "with_noise",
    "cluster_taus", "extra_term_starts", "nnls_spectrum", "one_term_starts", "tau_grid",
    "Applied", "Basis", "Param", "Structure", "basis", "taus_of",
]

#: The modules that give this package its names, each after those it imports.
_MODULES = ("data", "structure", "noise", "solver", "evidence", "starts", "prony", "circuit")


def __getattr__(name: str):
    if name in __all__:
        for module in _MODULES:
            found = import_module(f"creepcomp.fit.{module}")
            if hasattr(found, name):
                globals()[name] = value = getattr(found, name)
                return value
    raise AttributeError(f"module 'creepcomp.fit' has no attribute {name!r}")


def __dir__():
    return sorted(set(globals()) | set(__all__))
