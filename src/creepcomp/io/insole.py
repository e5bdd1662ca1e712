"""Capacitive pressure-sensing insoles pressed in an air chamber (MATLAB ``.mat`` files).

Each file holds a struct ``experiment`` with ``C`` (N x 282: a message counter, a timestamp in
seconds, then the raw capacitance counts of 280 taxels) and ``P`` (M x 1: the chamber pressure
in bar, logged apart, with no timestamp and M != N). The two channels are aligned as the
authors' own code does, by keeping the first ``min(N, M)`` rows of both; the time of a row is
``C``'s timestamp. A record is one taxel: ``signal`` = its counts (which fall under pressure,
so the fitted gain is negative), ``load`` = the pressure.

Broken taxels (dropouts towards 0, the converter's full scale, or no movement) are refused
with the reason, unless asked for explicitly; :func:`rank_taxels` orders the taxels by how
closely they follow the pressure.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from creepcomp.errors import InputError
from creepcomp.io.inputs import check_input_file
from creepcomp.io.records import Record

__all__ = ["N_TAXELS", "FULL_SCALE", "DROPOUT_BELOW", "InsoleFile", "read_insole_file",
           "taxel_problems", "rank_taxels", "working_taxels", "insole_record", "read_insole"]

N_TAXELS = 280
#: The counts are 8-bit: a taxel at 255 is clipped.
FULL_SCALE = 255
#: A working taxel reads about 240 at rest and falls by a few tens under 3 bar; a reading below
#: this is a dropout of a broken taxel (the insole authors exclude such taxels too).
DROPOUT_BELOW = 100
#: Fewest counts a taxel must move over the record to count as moving (1 count is quantisation).
MIN_RANGE = 2


@dataclass(frozen=True)
class InsoleFile:
    """The channels of an insole file, cut to a common length.

    Attributes
    ----------
    time : numpy.ndarray
        ``C``'s timestamp column (s), first ``n`` rows.
    pressure : numpy.ndarray
        ``P`` (bar), first ``n`` rows.
    counts : numpy.ndarray
        n x 280 taxel counts.
    rows_taxels, rows_pressure : int
        Rows of ``C`` and ``P`` before cutting (N and M).
    source : str
    """

    time: np.ndarray
    pressure: np.ndarray
    counts: np.ndarray
    rows_taxels: int
    rows_pressure: int
    source: str

    @property
    def alignment(self) -> str:
        """How the channels were aligned, in words."""
        n = len(self.time)
        return (f"first {n} rows of both channels kept (taxels had {self.rows_taxels} rows, pressure "
                f"{self.rows_pressure}; the channels carry no common clock)")


def read_insole_file(path: str | Path) -> InsoleFile:
    """Read an insole ``.mat`` file and cut its two channels to the same length.

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    InsoleFile

    Raises
    ------
    InputError
        When the file is missing, not a MATLAB file, or lacks ``experiment.C`` / ``experiment.P``.
    """
    from scipy.io import loadmat
    from scipy.io.matlab import MatReadError

    p = Path(path)
    check_input_file(p, "insole file")
    try:
        mat = loadmat(str(p), squeeze_me=True, struct_as_record=False)
    except (MatReadError, ValueError, TypeError, OSError, NotImplementedError) as exc:
        raise InputError(f"{p}: not a readable MATLAB file ({exc})") from None
    exp = mat.get("experiment")
    if exp is None or not hasattr(exp, "C") or not hasattr(exp, "P"):
        raise InputError(f"{p}: no struct 'experiment' with fields C and P (variables found: "
                         f"{', '.join(k for k in mat if not k.startswith('__')) or 'none'})")
    c = np.atleast_2d(np.asarray(exp.C, dtype=float))
    pressure = np.asarray(exp.P, dtype=float)
    if pressure.ndim > 1 and sorted(pressure.shape)[-2] > 1:
        raise InputError(f"{p}: experiment.P has shape {' x '.join(map(str, pressure.shape))}, "
                         "expected one column (the chamber pressure, bar)")
    pressure = pressure.ravel()
    if c.shape[1] != N_TAXELS + 2:
        raise InputError(f"{p}: experiment.C has {c.shape[1]} columns, expected {N_TAXELS + 2} "
                         "(counter, timestamp, 280 taxels)")
    n = min(len(c), len(pressure))
    if n == 0:
        raise InputError(f"{p}: experiment.C or experiment.P is empty")
    return InsoleFile(time=c[:n, 1], pressure=pressure[:n], counts=c[:n, 2:],
                      rows_taxels=len(c), rows_pressure=len(pressure), source=str(p))


def taxel_problems(counts: np.ndarray, time: np.ndarray | None = None) -> list[str]:
    """What is wrong with one taxel's counts: dropouts, clipping, no movement (empty: none).

    Parameters
    ----------
    counts : numpy.ndarray
        One taxel's counts.
    time : numpy.ndarray, optional
        Sample times (s), to say where a problem starts.
    """
    x = np.asarray(counts, dtype=float)
    where = (lambda i: f" (first at t = {time[i] - time[0]:.2f} s from the start)") if time is not None \
        else (lambda i: f" (first at sample {i})")
    out = []
    if np.all(x == 0):
        return ["reads 0 throughout"]
    low = np.flatnonzero(x < DROPOUT_BELOW)
    if low.size:
        out.append(f"drops to {x.min():.0f} counts in {low.size} samples{where(low[0])}: a broken "
                   f"taxel's dropouts (working taxels stay above {DROPOUT_BELOW})")
    high = np.flatnonzero(x >= FULL_SCALE)
    if high.size:
        out.append(f"reaches the converter's full scale ({FULL_SCALE}) in {high.size} samples"
                   f"{where(high[0])}: clipped")
    if np.ptp(x) < MIN_RANGE:
        out.append(f"does not move (range {np.ptp(x):.0f} counts over the record)")
    return out


def working_taxels(insole: InsoleFile, top: int = 5) -> str:
    """The ``top`` working taxels that follow the pressure best, as text for messages."""
    good = [str(r["taxel"]) for r in rank_taxels(insole) if not r["problems"]][:top]
    return ", ".join(good) or "none (every taxel has a problem)"


def rank_taxels(insole: InsoleFile, top: int | None = None) -> list[dict]:
    """Taxels ordered by how closely their counts follow the pressure, working ones first.

    Each entry has ``taxel`` (0..279), ``correlation`` with the pressure (negative: counts fall
    under pressure), ``sensitivity`` (counts per bar, least squares), ``range`` (counts) and
    ``problems`` (see :func:`taxel_problems`).
    """
    x = insole.counts
    pc = insole.pressure - insole.pressure.mean()
    xc = x - x.mean(axis=0)
    norm = np.sqrt(np.einsum("ij,ij->j", xc, xc)) * np.linalg.norm(pc)
    cov = pc @ xc
    corr = np.divide(cov, norm, out=np.zeros_like(cov), where=norm > 0)
    sens = cov / (pc @ pc) if np.any(pc) else np.zeros_like(cov)
    rows = [{"taxel": j, "correlation": float(corr[j]), "sensitivity": float(sens[j]),
             "range": float(np.ptp(x[:, j])), "problems": taxel_problems(x[:, j], insole.time)}
            for j in range(x.shape[1])]
    rows.sort(key=lambda r: (bool(r["problems"]), -abs(r["correlation"])))
    return rows[:top] if top else rows


def insole_record(insole: InsoleFile, taxel: int, allow_broken: bool = False) -> Record:
    """One taxel of an insole file as a record: ``load`` = pressure (bar), ``signal`` = counts.

    Parameters
    ----------
    insole : InsoleFile
    taxel : int
        0..279 (column ``2 + taxel`` of ``C``).
    allow_broken : bool
        Return a taxel with problems (listed in ``metadata["insole.problems"]``) instead of
        refusing it.

    Raises
    ------
    InputError
        For a taxel out of range, or a broken one (naming the problem and good taxels).
    """
    if not 0 <= int(taxel) < N_TAXELS:
        raise InputError(f"{insole.source}: taxel {taxel} does not exist (0 to {N_TAXELS - 1})")
    taxel = int(taxel)
    counts = insole.counts[:, taxel]
    problems = taxel_problems(counts, insole.time)
    if problems and not allow_broken:
        raise InputError(f"{insole.source}: taxel {taxel} {'; '.join(problems)}; taxels that follow "
                         f"the pressure best: {working_taxels(insole)}")
    metadata = {"units.load": "bar", "units.signal": "counts", "insole.taxel": str(taxel),
                "insole.alignment": insole.alignment,
                "insole.sign": "the counts fall as the pressure rises: the gain is negative"}
    if problems:
        metadata["insole.problems"] = "; ".join(problems)
    return Record(time=insole.time, load=insole.pressure, signal=counts, metadata=metadata,
                  source=f"{insole.source} (taxel {taxel})")


def read_insole(path: str | Path, taxel: int, allow_broken: bool = False) -> Record:
    """Read one taxel of an insole ``.mat`` file as a record (see :func:`insole_record`)."""
    return insole_record(read_insole_file(path), taxel, allow_broken=allow_broken)
