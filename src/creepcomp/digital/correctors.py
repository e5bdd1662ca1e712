"""Digital creep correction (paper section III): exact, recursive, batch and streaming.

The raw signal is the instantaneous signal through the creep model, ``x = G[S]`` with
``x = signal - offset`` and ``S = gain * load`` (``docs/physics.md``, sections 1-2).
Sampled, with the load held between samples (``hold="zero"``, the paper's assumption) or
ramping linearly between them (``hold="linear"``), each creep term is a first-order lag
discretised exactly by :func:`creepcomp.lti.lag_coefficients`::

    c_k[n+1] = e_k c_k[n] + b0_k S[n] + b1_k S[n+1],      x[n] = S[n] + sum_k beta_k c_k[n]

The correction solves this for ``S[n]`` sample by sample. With ``q_k[n] = c_k[n] - b1_k S[n]``
(the part of the creep state known before sample ``n``) the equation is linear in ``S[n]``::

    S[n] = (x[n] - beta . q[n]) / D,     D = 1 + beta . b1,
    q[n+1] = e q[n] + (e b1 + b0) S[n]

For zero hold ``b1 = 0``, ``q = c`` and this is the paper's eq. 7/9 in recursive form (the
current increment adds no creep at its own instant): ``c <- e c + (1 - e) S`` is the update
``m <- exp(-dt/tau) (m + dS)`` of the creep still to come, ``m[n] = S[n-1] - c[n]``. O(1) per sample and
term, no overflow at any ``t / tau``.

- **subtractive**: the estimate of the instantaneous signal, ``offset + S``.
- **supplemental**: the estimate of the saturated signal, ``offset + (1 + beta0) S``: the
  paper's implicit eq. 11 with gains ``beta_k / (1 + beta0)``, solved for the current sample
  (it is linear in it) instead of lagging one step (eq. 12).

Over temperature (a model with a temperature law, ``docs/physics.md``): every step has its
own coefficients, ``e_k``, ``b0_k``, ``b1_k`` of ``tau_k a_T`` at the step's mid temperature
and ``beta_k(T)`` at the sample (:meth:`creepcomp.model.CreepModel.step_lags`), exactly the
inverse of :meth:`~creepcomp.model.CreepModel.response` with that temperature history::

    S[n] = (x[n] - beta[n] . q[n]) / D[n],      D[n] = 1 + beta[n] . b1[n-1],
    q[n+1] = e[n] q[n] + (e[n] b1[n-1] + b0[n]) S[n]

The supplemental scale stays ``1 + beta0`` at the reference temperature, so that its output
depends on the load alone.

Both are the inverse filter ``1/G`` (times ``G(0)``); they differ in scale and in the usual
start: relaxed (unloaded) for subtractive, settled (creep saturated) for supplemental. Either
start works with either method.

How it runs: the recursion for ``q`` is a lower-triangular banded linear system, solved by
LAPACK's ``dtbtrs`` (compiled forward substitution, exactly the recursion; any time steps).
For uniform sampling the samples are grouped in blocks of :data:`BLOCK`: within a block the
output is a small matrix product with the exact impulse response, and only the block-to-block
state goes through the recursion. A direct-form IIR filter of order K (one ``lfilter`` call
with the polynomial coefficients of ``1/G(z)``) is not exact: its poles crowd near ``z = 1``
and rounding the polynomial's coefficients moves them (three terms of 20-100 s: error 3e-5 of
the signal at 100 Hz, 3 % at 1 kHz; see ``benchmarks/digital_throughput.py``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.linalg import lapack

from creepcomp.errors import InputError
from creepcomp.lti import UNIFORM_RTOL, lag_coefficients
from creepcomp.model import CreepModel

__all__ = ["ERROR_CHUNK", "CHUNK", "METHODS", "HOLDS", "INITIAL_STATES", "BLOCK", "PASS_SAMPLES", "default_initial",
           "saturation_factor", "Corrector", "check_invertible", "check_temperature", "compensate",
           "uniform_interval", "uniform_interval_of", "reference", "CreepError", "CreepErrorSum",
           "creep_error", "fitted_reference_error",
           "FittedReferenceSum", "estimate_load", "load_from_compensated", "load_from_linear",
           "filter_load", "mean_interval", "mean_interval_of"]

METHODS = ("subtractive", "supplemental")
HOLDS = ("zero", "linear")
INITIAL_STATES = ("relaxed", "settled")

#: Samples per block of the uniform-sampling engine (the block's output is a BLOCK x BLOCK
#: matrix product; the recursion runs once per block).
BLOCK = 16
#: Largest number of samples handled in one pass (bounds the memory of the banded solver).
PASS_SAMPLES = 1 << 16
#: Samples :func:`compensate` feeds the :class:`Corrector` at a time (the result does not
#: depend on it).
CHUNK = 1_000_000


def default_initial(method: str) -> str:
    """The start the paper assumes for a method: ``relaxed`` (subtractive), ``settled``
    (supplemental)."""
    return "relaxed" if _check_method(method) == "subtractive" else "settled"


def saturation_factor(model: CreepModel, method: str) -> float:
    """Scale of the compensated signal over the instantaneous one: 1 or ``1 + beta0``."""
    return 1.0 if _check_method(method) == "subtractive" else 1.0 + model.beta0


def _check_method(method: str) -> str:
    if method not in METHODS:
        raise InputError(f"method '{method}': use 'subtractive' or 'supplemental'")
    return method


def check_temperature(model: CreepModel, given: bool, where: str = "correction") -> None:
    """Refuse a model with a temperature law and no temperature, or a temperature without a law.

    Parameters
    ----------
    model : CreepModel
    given : bool
        Whether a temperature (a record column or a constant) is there.
    where : str
        What needs it, for the message.
    """
    if model.temperature is not None and not given:
        law = model.temperature
        raise InputError(f"the model has a temperature law ({law.law}, reference "
                         f"{law.reference:g} °C): the {where} needs the temperature of every "
                         "sample: a 'temperature' column in the record (°C), or --temperature T "
                         "(°C) for a constant one")
    if model.temperature is None and given:
        raise InputError(f"a temperature was given for the {where} but the model has no "
                         "temperature law (no 'temperature' block): it cannot follow temperature; "
                         "drop the temperature or give a model with a law")


def _check_hold(hold: str) -> str:
    if hold not in HOLDS:
        raise InputError(f"hold '{hold}': use 'zero' (load held between samples) or 'linear'")
    return hold


def _affine_recursion(u, q0, M=None, diagonal=None, feedback=None, beta=None) -> np.ndarray:
    """Solve ``q[0] = q0``, ``q[i+1] = M[i] q[i] + u[i]`` with LAPACK's banded triangular solver.

    ``M`` is given densely, shape (K, K) (the same every step), or as
    ``diag(diagonal[i]) - outer(feedback[i], beta)`` with ``diagonal`` and ``feedback`` of
    shape (n - 1, K) and ``beta`` of shape (K,) or, one per step, (n - 1, K).

    Returns
    -------
    numpy.ndarray, shape (n, K)
    """
    steps, k = u.shape
    n = steps + 1
    # unknowns ordered (i, k); row (i+1, r) holds -M[i][r, j] at column (i, j): band offset k + r - j
    ab = np.zeros((2 * k, n * k), order="F")
    for r in range(k):
        for j in range(k):
            row = ab[k + r - j, j:steps * k:k]
            if M is not None:
                row[:] = -M[r, j]
            else:
                np.multiply(feedback[:, r], beta[..., j], out=row)
                if r == j:
                    row -= diagonal[:, r]
    rhs = np.empty((n * k, 1))
    rhs[:k, 0] = q0
    rhs[k:, 0] = u.reshape(-1)
    q, info = lapack.dtbtrs(ab, rhs, uplo="L", diag="U", overwrite_b=1)
    if info != 0:
        raise RuntimeError(f"LAPACK dtbtrs failed (info = {info})")
    return q.reshape(n, k)


@dataclass(frozen=True)
class _UniformBlocks:
    """Exact block form of the inverse recursion for one time step (see module docstring)."""

    e: np.ndarray           # (K,) lag decay over one step
    b0: np.ndarray
    b1: np.ndarray
    D: float                # 1 + beta . b1
    M: np.ndarray           # (K, K): q[n+1] = M q[n] + h x[n]
    powers: np.ndarray      # (BLOCK + 1, K, K): M^i
    observe: np.ndarray     # (BLOCK, K): row i = (beta / D) M^i
    drive: np.ndarray       # (K, BLOCK): column m = M^(BLOCK-1-m) h
    output: np.ndarray      # (BLOCK, BLOCK): S_block = output @ x_block - observe @ Q

    @classmethod
    def build(cls, beta: np.ndarray, taus: np.ndarray, dt: float, hold: str) -> "_UniformBlocks":
        e, b0, b1 = (np.asarray(c, dtype=float) for c in lag_coefficients(dt, taus, hold))
        D = 1.0 + float(beta @ b1)
        B = e * b1 + b0
        h = B / D
        w = beta / D
        M = np.diag(e) - np.outer(h, beta)
        powers = np.empty((BLOCK + 1, len(beta), len(beta)))
        powers[0] = np.eye(len(beta))
        for i in range(1, BLOCK + 1):
            powers[i] = M @ powers[i - 1]
        observe = np.einsum("k,ikj->ij", w, powers[:BLOCK])
        drive = np.einsum("ikj,j->ki", powers[BLOCK - 1::-1], h)
        markov = observe[:BLOCK - 1] @ h                        # impulse response w M^j h
        i, m = np.indices((BLOCK, BLOCK))
        output = np.where(i == m, 1.0 / D, 0.0)
        lower = m < i
        output[lower] = -markov[(i - 1 - m)[lower]]
        return cls(e, b0, b1, D, M, powers, observe, drive, output)

    def run(self, x: np.ndarray, q: np.ndarray, out: np.ndarray) -> np.ndarray:
        """Compensate ``x`` (instantaneous estimate into ``out``) from state ``q`` at ``x[0]``;
        returns ``q`` at the last sample."""
        n = len(x)
        nb, rest = divmod(n, BLOCK)
        X = x[:nb * BLOCK].reshape(nb, BLOCK)
        starts = _affine_recursion(X @ self.drive.T, q, M=self.powers[BLOCK])     # (nb + 1, K)
        out[:nb * BLOCK] = (X @ self.output.T - starts[:nb] @ self.observe.T).reshape(-1)
        if rest:
            tail = x[nb * BLOCK:]
            out[nb * BLOCK:] = self.output[:rest, :rest] @ tail - self.observe[:rest] @ starts[nb]
            block_start, block_x, last = starts[nb], tail, rest - 1
        else:
            block_start, block_x, last = starts[nb - 1], X[-1], BLOCK - 1
        return self.powers[last] @ block_start + self.drive[:, BLOCK - last:] @ block_x[:last]


class Corrector:
    """Streaming creep correction: feed chunks of any size, as firmware would.

    Parameters
    ----------
    model : CreepModel
        The sensor's creep (``beta``, ``tau``, ``offset``; ``gain`` is not needed).
    method : {"subtractive", "supplemental"}
        Estimate the instantaneous signal, or the saturated one (``(1 + beta0)`` times it).
    dt : float, optional
        Sampling interval (s) for uniform sampling; then :meth:`process` takes samples only.
        Without it every chunk comes with its sample times (irregular sampling).
    initial : {"relaxed", "settled"} or array_like, optional
        Creep state at the first sample: none (unloaded long enough before), saturated at the
        first sample's level, or the states ``c_k`` (signal units above the offset).
        Default :func:`default_initial` of the method.
    hold : {"zero", "linear"}
        Load held between samples (the paper's assumption; exact for loads that change at
        sample instants) or ramping linearly between them.

    Notes
    -----
    The output of a chunk depends only on the samples fed so far; feeding a record in chunks
    gives the result of :func:`compensate` on the whole record (to rounding). A model with a
    temperature law needs the temperature (°C) of every sample with each chunk (module
    docstring).
    """

    def __init__(self, model: CreepModel, method: str = "subtractive", dt: float | None = None,
                 initial=None, hold: str = "zero"):
        self.model = model
        self.method = _check_method(method)
        self.hold = _check_hold(hold)
        self.initial = default_initial(method) if initial is None else initial
        if isinstance(self.initial, str) and self.initial not in INITIAL_STATES:
            raise InputError(f"initial state '{self.initial}': use 'relaxed', 'settled' or "
                             "an array of creep states")
        self._beta = np.array(model.beta)
        self._taus = np.array(model.tau)
        self._scale = saturation_factor(model, method)
        check_invertible(model)
        self.dt = None
        self._blocks = None
        if dt is not None:
            dt = float(dt)
            if not (dt > 0 and math.isfinite(dt)):
                raise InputError(f"dt = {dt!r}: the sampling interval must be positive and finite")
            self.dt = dt
            if model.temperature is None:
                self._blocks = _UniformBlocks.build(self._beta, self._taus, dt, self.hold)
                _check_stable(self._blocks.M, f"sampling interval {dt:g} s", model)
        self._creep = None          # c_k at the last sample (signal units above offset)
        self._last = None           # instantaneous signal S at the last sample
        self._time = None           # time of the last sample (irregular mode)
        self._temp = None           # temperature at the last sample (°C; temperature law)

    def __repr__(self) -> str:
        step = "irregular steps" if self.dt is None else f"dt {self.dt:.4g} s"
        state = "running" if self.started else "not started"
        return (f"<Corrector {self.method}, {self.model.n_terms} term{'s' if self.model.n_terms > 1 else ''}, "
                f"{step}, {self.hold} hold: {state}>")

    @property
    def started(self) -> bool:
        """True once a sample has been processed."""
        return self._creep is not None

    @property
    def creep_states(self) -> np.ndarray | None:
        """Creep states ``c_k`` at the last sample (signal units above offset), or None."""
        return None if self._creep is None else self._creep.copy()

    def process(self, signal, time=None, temperature=None) -> np.ndarray:
        """Compensate the next chunk of raw samples.

        Parameters
        ----------
        signal : array_like
            Raw samples (signal units).
        time : array_like, optional
            Their times (s); required without ``dt``, not allowed with it.
        temperature : array_like or float, optional
            Temperature of each sample (°C), or one for all; required for a model with a
            temperature law, refused without one.

        Returns
        -------
        numpy.ndarray
            Compensated samples (signal units): instantaneous (subtractive) or saturated
            (supplemental) estimate.
        """
        raw = np.asarray(signal, dtype=float).reshape(-1)
        t = None
        if self.dt is None:
            if time is None:
                raise InputError("irregular sampling: give the sample times with each chunk "
                                 "(or create the Corrector with dt for uniform sampling)")
            t = np.asarray(time, dtype=float).reshape(-1)
            if t.shape != raw.shape:
                raise InputError(f"{len(t)} times for {len(raw)} samples")
        elif time is not None:
            raise InputError("this Corrector has a fixed sampling interval dt: pass samples only")
        check_temperature(self.model, temperature is not None)
        temps = None
        if temperature is not None:
            temps = np.asarray(temperature, dtype=float)
            if temps.ndim and temps.size != raw.size:
                raise InputError(f"{temps.size} temperatures for {raw.size} samples")
            temps = np.broadcast_to(temps.reshape(-1) if temps.ndim else temps, raw.shape)
            if not np.isfinite(temps).all():
                bad = int(np.flatnonzero(~np.isfinite(temps))[0])
                raise InputError(f"temperature of sample {bad} of the chunk is not a finite number")
            self.model.temperature.shift(temps)             # refuses temperatures the law cannot take
        out = np.empty_like(raw)
        # one pass at a time, so that every step works on data still in cache
        for i0 in range(0, len(raw), PASS_SAMPLES):
            i1 = min(i0 + PASS_SAMPLES, len(raw))
            x = raw[i0:i1] - self.model.offset
            if not np.isfinite(x).all():
                bad = i0 + int(np.flatnonzero(~np.isfinite(x))[0])
                raise InputError(f"signal sample {bad} of the chunk is not a finite number")
            s = out[i0:i1]
            first = 0
            if not self.started:
                self._start(x[0], None if t is None else t[0], None if temps is None else temps[i0])
                s[0] = self._last
                first = 1
            if i1 - i0 > first:
                if temps is not None:
                    self._run_temperature(x[first:], None if t is None else t[i0 + first:i1],
                                          temps[i0 + first:i1], s[first:])
                elif t is None:
                    self._run_uniform(x[first:], s[first:])
                else:
                    self._run_irregular(x[first:], t[i0 + first:i1], s[first:])
            if self._scale != 1.0:
                s *= self._scale
            if self.model.offset != 0.0:
                s += self.model.offset
        return out

    def _start(self, x0: float, t0: float | None, temp0: float | None = None) -> None:
        k = len(self._beta)
        if t0 is not None:
            if not math.isfinite(t0):
                raise InputError(f"time {t0} is not a finite number")
            self._time = float(t0)
        beta = self._beta
        if temp0 is not None:
            self._temp = float(temp0)
            beta = beta * self.model.temperature.beta_factor(self._temp, k)
        if isinstance(self.initial, str):
            level = 0.0 if self.initial == "relaxed" else x0 / (1.0 + float(np.sum(beta)))
            c0 = np.full(k, level)
        else:
            c0 = np.asarray(self.initial, dtype=float).reshape(-1)
            if c0.shape != (k,) or not np.all(np.isfinite(c0)):
                raise InputError(f"initial creep states: expected {k} finite values, got {c0.size}")
        self._creep = c0
        self._last = x0 - float(beta @ c0)

    def _run_uniform(self, x: np.ndarray, out: np.ndarray) -> None:
        blk = self._blocks
        q = blk.e * self._creep + blk.b0 * self._last
        q_last = blk.run(x, q, out)
        self._last = float(out[-1])
        self._creep = q_last + blk.b1 * self._last

    def _steps(self, t: np.ndarray) -> np.ndarray:
        """Time steps into each sample of the chunk (from the last sample), checked."""
        dts = np.diff(t, prepend=self._time)
        if not (np.all(dts > 0) and math.isfinite(t[-1])):
            i = int(np.flatnonzero(~((dts > 0) & np.isfinite(t)))[0])
            if not math.isfinite(t[i]):
                raise InputError(f"time {t[i]} is not a finite number")
            raise InputError(f"time must be strictly increasing: {t[i]:g} s follows "
                             f"{(self._time if i == 0 else t[i - 1]):g} s")
        return dts

    def _run_irregular(self, x: np.ndarray, t: np.ndarray, out: np.ndarray) -> None:
        dts = self._steps(t)
        e, b0, b1 = lag_coefficients(dts[:, None], self._taus[None, :], self.hold)
        beta = self._beta
        D = 1.0 + b1 @ beta
        q0 = e[0] * self._creep + b0[0] * self._last
        h = (e[1:] * b1[:-1] + b0[1:]) / D[:-1, None]
        q = _affine_recursion(h * x[:-1, None], q0, diagonal=e[1:], feedback=h, beta=beta)
        out[:] = (x - q @ beta) / D
        self._last = float(out[-1])
        self._creep = q[-1] + b1[-1] * self._last
        self._time = float(t[-1])

    def _run_temperature(self, x: np.ndarray, t: np.ndarray | None, temps: np.ndarray,
                         out: np.ndarray) -> None:
        """The recursion with every step's own lags and every sample's own amplitudes."""
        dts = np.full(len(x), self.dt) if t is None else self._steps(t)
        taus, betas = self.model.step_lags(np.concatenate(([self._temp], temps)))
        beta = betas[1:]
        e, b0, b1 = lag_coefficients(dts[:, None], taus, self.hold)
        D = 1.0 + np.sum(b1 * beta, axis=1)
        q0 = e[0] * self._creep + b0[0] * self._last
        h = (e[1:] * b1[:-1] + b0[1:]) / D[:-1, None]
        q = _affine_recursion(h * x[:-1, None], q0, diagonal=e[1:], feedback=h, beta=beta[:-1])
        out[:] = (x - np.sum(q * beta, axis=1)) / D
        self._last = float(out[-1])
        self._creep = q[-1] + b1[-1] * self._last
        self._temp = float(temps[-1])
        if t is not None:
            self._time = float(t[-1])


def check_invertible(model: CreepModel) -> None:
    """Refuse a model whose inverse ``1/G`` is unstable (``G`` has a zero with Re >= 0)."""
    zeros = np.linalg.eigvals(np.diag(-1.0 / np.array(model.tau))
                              - np.outer(1.0 / np.array(model.tau), model.beta))
    if np.any(zeros.real >= 0):
        z = zeros[np.argmax(zeros.real)]
        raise InputError(f"the creep model's G(s) has a zero at s = {z:.4g} 1/s (not in the left "
                         "half-plane): its inverse is unstable and cannot correct a signal")


def _check_stable(M: np.ndarray, where: str, model: CreepModel) -> None:
    radius = float(np.max(np.abs(np.linalg.eigvals(M))))
    if radius >= 1.0:
        raise InputError(f"the discrete inverse of the creep model is unstable at {where} "
                         f"(spectral radius {radius:.6g}); sample faster or check the model")


def compensate(time, signal, model: CreepModel, method: str = "subtractive", initial=None,
               hold: str = "zero", progress=None, chunk: int = CHUNK,
               temperature=None) -> np.ndarray:
    """Creep-compensated signal of a whole record (uniform or irregular sampling).

    Parameters
    ----------
    time : array_like
        Strictly increasing sample times (s).
    signal : array_like
        Raw sensor signal at those times.
    model : CreepModel
        The sensor's creep; creep acts on ``signal - offset``. Its Prony terms, gain and
        offset are used; fitted ``extensions`` are not.
    method : {"subtractive", "supplemental"}
        Instantaneous estimate ``offset + gain * load``, or saturated estimate
        ``offset + (1 + beta0) * gain * load``.
    initial : {"relaxed", "settled"} or array_like, optional
        Start (see :class:`Corrector`); default relaxed for subtractive, settled for
        supplemental.
    hold : {"zero", "linear"}
        Load held between samples (exact for steps at sample instants) or ramping linearly.
    progress : callable, optional
        Called as ``progress(samples_done, samples)`` after each chunk.
    chunk : int
        Samples fed to the :class:`Corrector` at a time (the result does not depend on it).
    temperature : array_like or float, optional
        Temperature of each sample (°C), or one for the whole record: required for a model
        with a temperature law (each step then has its own ``tau_k(T)``, each sample its own
        ``beta_k(T)``), refused for a model without one.

    Returns
    -------
    numpy.ndarray
        The compensated signal in signal units.

    Examples
    --------
    A load step at 10 s seen by a sensor with 3 % of creep at 45 s, corrected back to the load:

    >>> import numpy as np
    >>> from creepcomp.lti import lag_states
    >>> from creepcomp.model import CreepModel
    >>> from creepcomp.digital.correctors import compensate
    >>> t = np.arange(0.0, 600.0, 0.1)
    >>> load = np.where(t >= 10.0, 1.0, 0.0)
    >>> signal = load + 0.03 * lag_states(t, load, [45.0], hold="zero")[:, 0]
    >>> corrected = compensate(t, signal, CreepModel(beta=(0.03,), tau=(45.0,)))
    >>> print(f"creep before: {np.max(np.abs(signal - load)):.3f} of the step")
    creep before: 0.030 of the step
    >>> bool(np.max(np.abs(corrected - load)) < 1e-12)
    True
    """
    out = _linear_correction(time, signal, model, method, initial, hold, progress, chunk, temperature)
    return out if model.transfer is None else model.transfer.delinearise(out)


def _linear_correction(time, signal, model: CreepModel, method, initial, hold, progress, chunk,
                       temperature) -> np.ndarray:
    """:func:`compensate` in the signal map's linear domain (before ``h^-1``)."""
    t = np.asarray(time, dtype=float)
    x = np.asarray(signal, dtype=float)
    if t.ndim != 1 or x.shape != t.shape:
        raise InputError(f"time and signal must be 1-D of equal length (got {t.shape} and {x.shape})")
    steps = np.diff(t)
    if len(steps) and not (steps.min() > 0 and math.isfinite(t[0]) and math.isfinite(t[-1])):
        bad = np.flatnonzero(~(steps > 0))
        where = f"at sample {bad[0] + 1}" if bad.size else "(not finite)"
        raise InputError(f"time must be finite and strictly increasing {where}")
    dt = uniform_interval(t, steps)
    del steps
    check_temperature(model, temperature is not None)
    temps = None
    if temperature is not None:
        temps = np.asarray(temperature, dtype=float)
        if temps.ndim and temps.shape != x.shape:
            raise InputError(f"temperature has {temps.size} samples and the signal {x.size}")
        temps = np.broadcast_to(temps, x.shape)
    path = model.transfer
    if path is not None:
        x = path.linearise_within(x)
    if model.is_static:
        _check_method(method)
        out = x.copy()
        if progress:
            progress(len(x), len(x))
        return out
    corrector = Corrector(model, method, dt=dt, initial=initial, hold=hold)
    out = np.empty_like(x)
    for lo in range(0, len(x), max(int(chunk), 1)):
        hi = min(lo + int(chunk), len(x))
        part = None if temps is None else temps[lo:hi]
        out[lo:hi] = (corrector.process(x[lo:hi], temperature=part) if dt is not None
                      else corrector.process(x[lo:hi], t[lo:hi], temperature=part))
        if progress:
            progress(hi, len(x))
    return out


def load_from_compensated(compensated, model: CreepModel, method: str = "subtractive") -> np.ndarray:
    """The load that a compensated signal stands for: the rest of the model's inverse.

    ``f^-1( (h(compensated) - offset) / (gain * scale) )``, with ``scale`` 1 (subtractive) or
    ``1 + beta0`` (supplemental), ``h`` and ``f`` the model's static maps (identity without).
    """
    path = model.transfer
    z = np.asarray(compensated, dtype=float)
    return load_from_linear(z if path is None else path.linearise_within(z), model, method)


def load_from_linear(corrected, model: CreepModel, method: str = "subtractive") -> np.ndarray:
    """The load of a corrected value in the signal map's linear domain (the compensated signal
    before ``h^-1``): ``f^-1( (corrected - offset) / (gain * scale) )``."""
    load = (np.asarray(corrected, dtype=float) - model.offset) / (model.gain * saturation_factor(model, method))
    return load if model.transfer is None else model.transfer.load_out(load)


def estimate_load(time, signal, model: CreepModel, method: str = "subtractive", initial=None,
                  hold: str = "zero", temperature=None) -> np.ndarray:
    """The load of every sample: the whole model's inverse, static maps included.

    The signal is linearised by the model's signal map, its creep removed by the exact
    correction (:func:`compensate`), and the result mapped back through gain, offset and the
    load map: in load units, what a static calibration gives for a sensor without creep.

    Parameters
    ----------
    time, signal : array_like
        Strictly increasing sample times (s) and the raw signal.
    model : CreepModel
        A model without fitted ``extensions`` (those are inverted by the diagnosis's
        :func:`creepcomp.diagnose.effects.compensate_extended`, then
        :func:`load_from_compensated`).
    method, initial, hold, temperature
        As for :func:`compensate`; the load does not depend on the method.

    Returns
    -------
    numpy.ndarray
        The load estimate in load units.

    Examples
    --------
    A resistive pad read as a resistance: conductance linear in load, 20 % of creep at 5 s:

    >>> import numpy as np
    >>> from creepcomp.model import CreepModel
    >>> from creepcomp.transfer import StaticMap, Transfer
    >>> from creepcomp.digital.correctors import estimate_load
    >>> model = CreepModel((0.2,), (5.0,), gain=1e-4, offset=1e-4,
    ...                    transfer=Transfer(signal_map=StaticMap("reciprocal", {"origin": 0.0})))
    >>> t = np.arange(0.0, 60.0, 0.05)
    >>> load = np.where(t >= 10.0, 3.0, 0.0)
    >>> resistance = model.response(t, load, hold="zero")
    >>> print(f"{resistance[0]:.0f} ohm unloaded, {resistance[-1]:.0f} ohm after 50 s at 3 N")
    10000 ohm unloaded, 2174 ohm after 50 s at 3 N
    >>> bool(np.max(np.abs(estimate_load(t, resistance, model) - load)) < 1e-9)
    True
    """
    corrected = _linear_correction(time, signal, model, method, initial, hold, None, CHUNK, temperature)
    return filter_load(load_from_linear(corrected, model, method), model, time)


def filter_load(load, model: CreepModel, time=None, history=None) -> np.ndarray:
    """The model's load filter (:mod:`creepcomp.load_filter`) applied to a load estimate: the
    estimate itself for a model without one.

    Parameters
    ----------
    load : array_like
        The load estimate of every sample, unfiltered.
    model : CreepModel
    time : array_like, optional
        The sample times (s): the filter averages over the time it was chosen for, at the
        record's mean interval (without them: its own number of samples).
    history : array_like, optional
        The unfiltered estimates just before these (a record corrected piece by piece).
    """
    if model.load_filter is None:
        return np.asarray(load, dtype=float)
    return model.load_filter.apply(load, mean_interval(time), history)


def mean_interval(time) -> float | None:
    """A record's mean sample interval (s), or None for fewer than two samples."""
    if time is None or len(time) < 2:
        return None
    return mean_interval_of(time[0], time[-1], len(time))


def mean_interval_of(first: float, last: float, samples: int) -> float:
    """The mean sample interval (s) of ``samples`` samples from ``first`` to ``last`` (s)."""
    return float((last - first) / (samples - 1))


def uniform_interval(time, steps=None) -> float | None:
    """The sampling interval when all time steps are equal (to rounding), else None.

    Steps count as equal when they differ from their mean by at most ``UNIFORM_RTOL * dt``
    plus the rounding of the times themselves (4 ulp of the largest): a long record's times,
    written as decimals, carry that rounding. The recursion depends only on the steps, so the
    uniform engine is then exact to far below 1e-12 of the signal.

    Parameters
    ----------
    time : array_like
        Strictly increasing times (s).
    steps : array_like, optional
        ``numpy.diff(time)``, when already computed.
    """
    t = np.asarray(time, dtype=float)
    if len(t) < 2:
        return None
    d = np.diff(t) if steps is None else steps
    return uniform_interval_of(float(t[0]), float(t[-1]), len(t), float(d.min()), float(d.max()))


def uniform_interval_of(first: float, last: float, samples: int, step_min: float,
                        step_max: float) -> float | None:
    """:func:`uniform_interval` from a record's first and last times, length and extreme
    steps (as a pass over a record file gives them)."""
    if samples < 2:
        return None
    dt = (last - first) / (samples - 1)
    tolerance = UNIFORM_RTOL * dt + 4 * np.finfo(float).eps * max(abs(first), abs(last))
    if not (dt > 0 and step_max - dt <= tolerance and dt - step_min <= tolerance):
        return None
    return float(dt)


def reference(load, model: CreepModel, method: str = "subtractive") -> np.ndarray:
    """What an exact correction returns for a load: ``offset + gain * load`` (subtractive) or
    ``offset + (1 + beta0) * gain * load`` (supplemental)."""
    path = model.transfer
    u = np.asarray(load, dtype=float) if path is None else path.load_in(load)
    linear = model.offset + model.gain * saturation_factor(model, method) * u
    return linear if path is None else path.delinearise(linear)


@dataclass(frozen=True)
class CreepError:
    """Remaining creep error of a signal against the load reference.

    Attributes
    ----------
    rms, peak : float
        RMS and largest absolute error (signal units).
    peak_time : float
        Time of the largest error (s).
    full_scale : float
        Largest ``|reference - offset|`` in the record (signal units): the full-scale output.
    """

    rms: float
    peak: float
    peak_time: float
    full_scale: float

    @property
    def rms_fraction(self) -> float | None:
        """RMS error as a fraction of full scale (None when the load is zero throughout)."""
        return self.rms / self.full_scale if self.full_scale > 0 else None

    @property
    def peak_fraction(self) -> float | None:
        """Peak error as a fraction of full scale (None when the load is zero throughout)."""
        return self.peak / self.full_scale if self.full_scale > 0 else None

    def to_dict(self) -> dict:
        """JSON form: signal units, seconds and fractions of full scale."""
        return {"rms": self.rms, "peak": self.peak, "peak_time": self.peak_time,
                "rms_fraction": self.rms_fraction, "peak_fraction": self.peak_fraction,
                "full_scale": self.full_scale}


#: Samples per pass of :func:`creep_error` (its temporaries stay this size on long records).
ERROR_CHUNK = 1 << 20


class CreepErrorSum:
    """The creep error of a signal given piece by piece (running sum of squares, peak, full
    scale): :func:`creep_error` of the whole, in the memory of one piece."""

    def __init__(self, model: CreepModel, method: str = "subtractive"):
        self.model, self.method = model, _check_method(method)
        self.samples, self.squares, self.peak, self.peak_time, self.full_scale = 0, 0.0, -1.0, math.nan, 0.0

    def add(self, time: np.ndarray, values: np.ndarray, load: np.ndarray) -> None:
        """Take the next samples (times in s, values and load as :func:`creep_error`)."""
        if len(time) == 0:
            return
        ref = reference(load, self.model, self.method)
        err = values - ref
        self.squares += float(np.sum(err ** 2))
        k = int(np.argmax(np.abs(err)))
        if abs(err[k]) > self.peak:
            self.peak, self.peak_time = float(abs(err[k])), float(time[k])
        self.full_scale = max(self.full_scale, float(np.max(np.abs(ref - self.model.offset))))
        self.samples += len(time)

    def result(self) -> CreepError:
        """The error of all samples taken."""
        return CreepError(rms=math.sqrt(self.squares / self.samples), peak=self.peak,
                          peak_time=self.peak_time, full_scale=self.full_scale)


def creep_error(time, values, load, model: CreepModel, method: str = "subtractive",
                chunk: int = ERROR_CHUNK) -> CreepError:
    """Error of ``values`` (raw or compensated) against the method's load reference.

    The reference is :func:`reference` (instantaneous for subtractive, saturated for
    supplemental); full scale is its largest excursion from the offset in the record. Long
    records are taken ``chunk`` samples at a time (:class:`CreepErrorSum`), so memory does
    not grow with them.
    """
    t = np.asarray(time, dtype=float)
    v = np.asarray(values, dtype=float)
    load = np.asarray(load, dtype=float)
    if v.shape != t.shape or load.shape != t.shape or t.ndim != 1 or len(t) == 0:
        raise InputError("time, values and load must be 1-D of equal, non-zero length")
    total = CreepErrorSum(model, method)
    step = max(int(chunk), 1)
    for lo in range(0, len(t), step):
        total.add(t[lo:lo + step], v[lo:lo + step], load[lo:lo + step])
    return total.result()


def fitted_reference_error(values, load) -> np.ndarray:
    """Error of ``values`` (a creep-corrected signal) against the load scaled to it by least
    squares (gain and offset fitted): how well its shape follows the load, whatever the
    model's calibration. Its RMS is the diagnosis's correction-error figure."""
    v = np.asarray(values, dtype=float)
    design = np.column_stack([np.asarray(load, dtype=float), np.ones(len(v))])
    coef, *_ = np.linalg.lstsq(design, v, rcond=None)
    return v - design @ coef


class FittedReferenceSum:
    """RMS of :func:`fitted_reference_error` over a record taken in pieces (sums of the
    values and the load about their first samples, so that no precision is lost to offsets)."""

    def __init__(self):
        self._origin = None
        self._sums = np.zeros(6)                # n, x, y, xx, xy, yy

    def add(self, values, load) -> None:
        v = np.asarray(values, dtype=float)
        x = np.asarray(load, dtype=float)
        if len(v) == 0:
            return
        if self._origin is None:
            self._origin = (float(x[0]), float(v[0]))
        x = x - self._origin[0]
        v = v - self._origin[1]
        self._sums += (len(v), x.sum(), v.sum(), x @ x, x @ v, v @ v)

    def result(self) -> float | None:
        """The RMS error (values' units); None when the load does not vary."""
        n, sx, sy, sxx, sxy, syy = self._sums
        if n == 0:
            return None
        cxx, cxy, cyy = sxx - sx * sx / n, sxy - sx * sy / n, syy - sy * sy / n
        if cxx <= 0:
            return None
        return float(np.sqrt(max(cyy - cxy * cxy / cxx, 0.0) / n))
