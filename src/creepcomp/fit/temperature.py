"""Creep over temperature from records: one set of Prony terms at a reference temperature and
the law that shifts them (Arrhenius or WLF, optionally amplitudes per kelvin), fitted jointly
to several records at different temperatures (the way a master curve is built) or to one
record whose temperature changes.

Every record's prediction is the common model's response to its load and temperature history
(:meth:`creepcomp.model.CreepModel.response`), scaled by the record's own gain and shifted by
its own offset: a sensor's sensitivity and zero drift with temperature and records made on
different occasions are zeroed apart, so sharing them would turn those drifts into creep. The
terms and their law are common; each record's gain, offset and (``free`` start) initial creep
states are linear and projected out (variable projection), and the rest is refined by least
squares. Uncertainties come from the Jacobian with each record's own AR noise
(:func:`creepcomp.fit.solver.sandwich_covariance`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np
from scipy import linalg, optimize

from creepcomp.errors import InputError
from creepcomp.fit.data import Data
from creepcomp.fit.evidence import BIC_STRONG
from creepcomp.fit.noise import ARNoise, ar_order, fit_noise, gaussian_bic, rows_for, whiten
from creepcomp.fit.prony import fit_prony, fit_terms
from creepcomp.fit.solver import best_of_starts, sandwich_covariance
from creepcomp.fit.starts import tau_grid
from creepcomp.fit.structure import Param
from creepcomp.model import CreepModel
from creepcomp.temperature import GAS_CONSTANT, LAWS, ZERO_CELSIUS, TemperatureLaw

__all__ = ["CONSTANT_TEMPERATURE_TOLERANCE", "ACTIVATION_ENERGY_STARTS", "WLF_C2_STARTS", "record_temperature",
           "default_reference", "TemperatureFit", "fit_temperature_law"]

#: A record whose temperature stays within this many kelvin of its mean is taken at its mean
#: (the sensor's noise and small drifts are not fed into the retardation times).
CONSTANT_TEMPERATURE_TOLERANCE = 0.5
#: Activation energies (J/mol) the search starts from, besides the records' own estimate.
ACTIVATION_ENERGY_STARTS = (0.0, 25e3, 50e3, 100e3, 200e3)
#: WLF ``c2`` values (K) the search starts from (``c1`` then follows the Arrhenius slope).
WLF_C2_STARTS = (50.0, 120.0, 300.0)


def record_temperature(data: Data, given: float | None = None,
                       tolerance: float = CONSTANT_TEMPERATURE_TOLERANCE) -> np.ndarray:
    """Temperature (°C) at every sample of a record: ``given``, or the record's temperature
    column, replaced by its mean when it stays within ``tolerance`` K of it.

    Raises
    ------
    InputError
        Without either, naming the record.
    """
    if given is not None:
        return np.full(data.n, float(given))
    if data.temperature is None:
        raise InputError(f"{data.source}: no temperature column; give one temperature per record "
                         "(--temperature T1,T2,...)")
    t = np.asarray(data.temperature, float)
    if not np.all(np.isfinite(t)):
        raise InputError(f"{data.source}: the temperature column holds a value that is not a number")
    mean = float(np.mean(t))
    return np.full(data.n, mean) if np.max(np.abs(t - mean)) <= tolerance else t


def default_reference(temperatures: Sequence[np.ndarray]) -> float:
    """Reference temperature (°C): the mean of one record's samples, the median of several
    records' mean temperatures (the middle record); rounded to 0.1 °C."""
    if len(temperatures) == 1:
        return round(float(np.mean(temperatures[0])), 1)
    return round(float(np.median([np.mean(t) for t in temperatures])), 1)


def _law_params(law: str, reference: float, t_min: float) -> list[Param]:
    if law == "arrhenius":
        return [Param("activation_energy", 0.0, 500e3, scale=1e4, default=50e3)]
    # the WLF shift is singular at T_ref - c2: keep every sample's temperature above it
    c2_low = max(reference - t_min, 0.0) + 1.0
    return [Param("c1", 0.0, 100.0, scale=10.0, default=10.0),
            Param("c2", c2_low, 2000.0, scale=100.0, default=max(100.0, 2 * c2_low))]


def _law_of(law: str, reference: float, values: dict, n_terms: int, per_kelvin: bool,
            uncertainty: dict | None = None) -> TemperatureLaw:
    bpk = tuple(values[f"beta_per_kelvin[{k}]"] for k in range(n_terms)) if per_kelvin else ()
    return TemperatureLaw(reference, law, values.get("activation_energy"), values.get("c1"),
                          values.get("c2"), bpk, uncertainty or {})


class _Joint:
    """Least squares of one temperature-dependent model over several records."""

    def __init__(self, records: Sequence[Data], temperatures: Sequence[np.ndarray], law: str,
                 reference: float, n_terms: int, per_kelvin: bool):
        self.records, self.temperatures = list(records), [np.asarray(t, float) for t in temperatures]
        self.law, self.reference, self.n_terms, self.per_kelvin = law, reference, n_terms, per_kelvin
        lo = min(d.tau_limits()[0] for d in records)
        hi = max(d.tau_limits()[1] for d in records)
        t_min = min(float(np.min(t)) for t in self.temperatures)
        # tau at the reference may lie outside every record's window when the records are far from it
        self.params = ([Param(f"tau[{k}]", lo / 100.0, hi * 100.0, log=True) for k in range(n_terms)]
                       + [Param(f"beta[{k}]", -0.9, 10.0, scale=0.01) for k in range(n_terms)]
                       + _law_params(law, reference, t_min)
                       + ([Param(f"beta_per_kelvin[{k}]", -0.2, 0.2, scale=1e-3) for k in range(n_terms)]
                          if per_kelvin else []))
        # residuals relative to each record's signal range: records in other units weigh alike
        self.scales = [d.signal_scale for d in records]

    def values(self, x: np.ndarray) -> dict:
        return {p.name: p.from_search(v) for p, v in zip(self.params, x)}

    def start_vector(self, values: dict) -> np.ndarray:
        return np.array([p.to_search(p.clip(values.get(p.name, p.default))) for p in self.params])

    def model(self, values: dict) -> CreepModel:
        k = range(self.n_terms)
        law = _law_of(self.law, self.reference, values, self.n_terms, self.per_kelvin)
        return CreepModel(tuple(values[f"beta[{i}]"] for i in k), tuple(values[f"tau[{i}]"] for i in k),
                          1.0, 0.0, {}, law)

    def columns(self, r: int, model: CreepModel) -> tuple[np.ndarray, list[str]]:
        """The record's linear basis: offset, gain (the model's response), and in a ``free``
        start the decay of each term's initial creep state."""
        d, temp = self.records[r], self.temperatures[r]
        if d.initial == "free":
            initial = "settled"
        elif d.initial == "step":
            taus0 = np.array(model.tau) * float(model.temperature.shift(temp[0]))
            initial = d.lag_initial(d.load, taus0)
        else:
            initial = d.initial
        cols, names = [], []
        if not d.fixed_offset:
            cols.append(np.ones(d.n))
            names.append("offset")
        cols.append(model.response(d.sampling, d.load, hold=d.hold, initial=initial, temperature=temp))
        names.append("gain")
        if d.initial == "free":
            zero = np.zeros(d.n)
            for k in range(self.n_terms):
                cols.append(model.response(d.sampling, zero, hold=d.hold, initial=np.eye(self.n_terms)[k],
                                           temperature=temp))
                names.append(f"c0[{k}]")
        return np.column_stack(cols), names

    def project(self, x: np.ndarray) -> tuple[list, list, list]:
        """Per record: basis and names, linear coefficients, weighted residual."""
        model = self.model(self.values(x))
        bases, coefs, residuals = [], [], []
        for r, d in enumerate(self.records):
            a, names = self.columns(r, model)
            norms = np.sqrt(np.einsum("ij,ij->j", a, a))
            norms[norms == 0] = 1.0
            # a reduced record's samples weighted by what each holds (Data.weighted)
            coef, *_ = linalg.lstsq(d.weighted(a / norms), d.weighted(d.signal), lapack_driver="gelsy",
                                    cond=1e-13)
            coef = coef / norms
            bases.append((a, names))
            coefs.append(coef)
            residuals.append(d.weighted(d.signal - a @ coef) / self.scales[r])
        return bases, coefs, residuals

    def residual(self, x: np.ndarray) -> np.ndarray:
        try:
            return np.concatenate(self.project(x)[2])
        except (InputError, FloatingPointError, ValueError, linalg.LinAlgError):
            return np.full(sum(d.n for d in self.records), 1e30)

    def refine(self, x0: np.ndarray) -> np.ndarray:
        lo, hi = zip(*(p.bounds() for p in self.params))
        res = optimize.least_squares(self.residual, x0, bounds=(lo, hi), method="trf", x_scale=1.0,
                                     max_nfev=60 * (len(x0) + 1), diff_step=1e-6,
                                     xtol=1e-8, ftol=1e-8, gtol=1e-8)
        return res.x

    def predictions(self, x: np.ndarray, coefs: list) -> list[np.ndarray]:
        """Each record's weighted prediction at ``x`` with the linear coefficients held."""
        model = self.model(self.values(x))
        return [self.columns(r, model)[0] @ c / self.scales[r] for r, c in enumerate(coefs)]

    def covariance(self, x: np.ndarray, bases: list, coefs: list, noises: list[ARNoise]) -> np.ndarray | None:
        """Sandwich covariance of (search coordinates, every record's linear coefficients)
        under each record's AR noise (records independent)."""
        n_lin = [len(c) for c in coefs]
        n_par = len(x) + sum(n_lin)
        blocks = [np.zeros((d.n, n_par)) for d in self.records]
        for j in range(len(x)):
            h = 1e-6 * max(1.0, abs(x[j]))
            xp, xm = x.copy(), x.copy()
            xp[j] += h
            xm[j] -= h
            for r, (p, m) in enumerate(zip(self.predictions(xp, coefs), self.predictions(xm, coefs))):
                blocks[r][:, j] = (p - m) / (2 * h)
        start = len(x)
        for r, (a, _) in enumerate(bases):
            blocks[r][:, start:start + n_lin[r]] = a / self.scales[r]
            start += n_lin[r]
        return sandwich_covariance(blocks, noises)


@dataclass(frozen=True)
class TemperatureFit:
    """A creep model with its temperature law, fitted to one or several records.

    Attributes
    ----------
    model : CreepModel
        Terms at the reference temperature and the law (its ``uncertainty`` filled); gain
        and offset of the record nearest the reference temperature.
    law : TemperatureLaw
    values, sigmas : dict
        Fitted nonlinear values (``tau[k]``, ``beta[k]``, law keys, ``beta_per_kelvin[k]``)
        and their standard deviations.
    records : tuple of dict
        Per record: source, temperatures, gain, offset (with standard deviations), residual.
    bic : float
        Information criterion (independent Gaussian errors on the weighted residuals).
    orders : tuple of dict
        The numbers of terms tried and their BIC.
    """

    model: CreepModel
    law: TemperatureLaw
    values: dict
    sigmas: dict
    records: tuple[dict, ...]
    bic: float
    n_params: int
    orders: tuple[dict, ...] = ()

    @property
    def n_terms(self) -> int:
        """Number of Prony terms."""
        return self.model.n_terms

    def law_estimates(self) -> dict[str, tuple[float, float]]:
        """The law's fitted keys: value and standard deviation (J/mol, or WLF c1 and c2 in K)."""
        keys = ("activation_energy",) if self.law.law == "arrhenius" else ("c1", "c2")
        return {k: (self.values[k], self.sigmas[k]) for k in keys}

    def to_dict(self) -> dict:
        """Model file: the model with its ``temperature`` block, plus ``uncertainty`` and
        ``fit`` statistics."""
        out = self.model.to_dict()
        k = range(self.n_terms)
        ref = min(self.records, key=lambda r: abs(r["temperature_mean"] - self.law.reference))
        out["uncertainty"] = {
            "beta": [self.sigmas[f"beta[{i}]"] for i in k], "tau": [self.sigmas[f"tau[{i}]"] for i in k],
            "gain": ref["gain_sigma"], "offset": ref["offset_sigma"],
            "note": "one standard deviation: Jacobian of the joint residual, each record's Gaussian "
                    "AR noise (sandwich), locally linear model"}
        out["fit"] = {
            "method": "joint fit of one model and its temperature law to every record (each "
                      "record with its own gain and offset)",
            "gain_offset_from": ref["record"],
            "records": list(self.records), "bic": self.bic, "n_params": self.n_params,
            "orders": list(self.orders)}
        return out


def _record_starts(records: Sequence[Data], temperatures: Sequence[np.ndarray], reference: float,
                   n_terms: int, ref_fit) -> list[dict]:
    """Start values: the reference record's terms with a grid of activation energies, and (from
    several records at distinct temperatures) the Arrhenius regression of each record's own
    retardation times."""
    taus = np.sort(ref_fit.taus)
    order = np.argsort(ref_fit.taus)
    betas = ref_fit.betas[order]
    base = {**{f"tau[{k}]": float(taus[k]) for k in range(n_terms)},
            **{f"beta[{k}]": float(betas[k]) for k in range(n_terms)}}
    starts = [{**base, "activation_energy": ea} for ea in ACTIVATION_ENERGY_STARTS]
    means = np.array([float(np.mean(t)) for t in temperatures])
    if len(records) >= 2 and np.ptp(means) > 2 * CONSTANT_TEMPERATURE_TOLERANCE:
        x = 1.0 / (means + ZERO_CELSIUS) - 1.0 / (reference + ZERO_CELSIUS)
        log_tau = []
        for d in records:
            fit = fit_terms(d, n_terms)
            log_tau.append(float(np.mean(np.log(fit.taus))))
        slope, intercept = np.polyfit(x, log_tau, 1)
        shift = math.exp(intercept - float(np.mean(np.log(taus))))
        starts.append({**base, **{f"tau[{k}]": float(taus[k] * shift) for k in range(n_terms)},
                       "activation_energy": max(float(slope) * GAS_CONSTANT, 0.0)})
    return starts


def _wlf_starts(arrhenius: dict, reference: float) -> list[dict]:
    """WLF starts with the Arrhenius fit's slope at the reference: ``c1 ln10 / c2 = kappa``."""
    kappa = arrhenius["activation_energy"] / (GAS_CONSTANT * (reference + ZERO_CELSIUS) ** 2)
    base = {k: v for k, v in arrhenius.items() if k != "activation_energy"}
    return [{**base, "c2": c2, "c1": kappa * c2 / math.log(10.0)} for c2 in WLF_C2_STARTS]


def _sd(param: Param, value: float, var: float) -> float:
    """Standard deviation in natural units of a parameter searched as ``param`` says."""
    sd = math.sqrt(max(var, 0.0))
    return value * sd if param.log else param.scale * sd


def _fit_order(records, temps, law: str, reference: float, n_terms: int, per_kelvin: bool,
               starts: list[dict], n_refine: int = 3) -> tuple[_Joint, np.ndarray]:
    """The joint fit with ``n_terms`` terms from ``starts`` (the ``n_refine`` of least cost
    refined): the problem and its search point. A WLF fit whose starts hold no ``c1`` starts
    from an Arrhenius fit's slope."""
    if law == "wlf" and "c1" not in starts[0]:
        problem, x = _fit_order(records, temps, "arrhenius", reference, n_terms, per_kelvin, starts,
                                n_refine)
        starts = _wlf_starts(problem.values(x), reference)
    problem = _Joint(records, temps, law, reference, n_terms, per_kelvin)
    return problem, best_of_starts(problem.residual, [problem.start_vector(s) for s in starts], n_refine,
                                   problem.refine)


def _added_term_starts(problem: _Joint, x: np.ndarray, grid: np.ndarray) -> list[dict]:
    """Starts with one term more than the fit ``(problem, x)``: its values plus a grid time
    of a tenth of its total amplitude."""
    values = problem.values(x)
    k = problem.n_terms
    taus = np.array([values[f"tau[{i}]"] for i in range(k)])
    beta0 = sum(values[f"beta[{i}]"] for i in range(k))
    return [{**values, f"tau[{k}]": float(tau), f"beta[{k}]": 0.1 * beta0}
            for tau in grid if np.min(np.abs(np.log(taus / tau))) >= 0.1]


def _whitened_bic(problem: _Joint, x: np.ndarray, noises: list[ARNoise]) -> float:
    """BIC of the prewhitened residuals (each record with its own noise and variance)."""
    _, coefs, residuals = problem.project(x)
    loglik, n = 0.0, 0
    for d, r, noise in zip(problem.records, residuals, noises):
        rows = rows_for(d)
        w = whiten(r, rows, noise)
        loglik += gaussian_bic(float(w @ w), len(rows), 0)[0]
        n += len(rows)
    k = len(problem.params) + sum(len(c) for c in coefs) + len(coefs)
    return -2.0 * loglik + k * math.log(n)


def _supported(larger: tuple, smaller: tuple) -> tuple[bool, float]:
    """Whether the larger model is supported: its BIC on prewhitened residuals (the AR noise of
    each record's residual under the larger model, for both) lower by :data:`BIC_STRONG`."""
    _, _, residuals = larger[0].project(larger[1])
    noises = [fit_noise(r, rows_for(d), ar_order(d)) for r, d in zip(residuals, larger[0].records)]
    delta = _whitened_bic(*larger, noises) - _whitened_bic(*smaller, noises)
    return delta < -BIC_STRONG, delta


def _bic(problem: _Joint, x: np.ndarray) -> tuple[float, int]:
    _, coefs, residuals = problem.project(x)
    r = np.concatenate(residuals)
    k = len(problem.params) + sum(len(c) for c in coefs) + 1
    return gaussian_bic(float(r @ r), len(r), k)[1], k


def _record_summary(d: Data, temp: np.ndarray, given: bool, names: list[str], coef: np.ndarray,
                    cov_lin: np.ndarray, residual: np.ndarray, law: TemperatureLaw, shift_sd: float) -> dict:
    sd = np.sqrt(np.clip(np.diag(cov_lin), 0, None)) if cov_lin is not None else np.full(len(coef), np.nan)
    by = dict(zip(names, zip(coef, sd)))
    raw = d.temperature
    used = ("given" if given else "mean of the column (constant within "
            f"{CONSTANT_TEMPERATURE_TOLERANCE:g} K)" if np.ptp(temp) == 0 else "column")
    mean = float(np.mean(temp))
    return {"record": d.source, "n_samples": d.n, "duration_s": d.duration,
            "temperature_mean": mean, "temperature_min": float(np.min(temp if raw is None or given else raw)),
            "temperature_max": float(np.max(temp if raw is None or given else raw)),
            "temperature_used": used,
            "shift_factor": float(law.shift(mean)), "shift_factor_sigma": shift_sd,
            "gain": float(by["gain"][0]), "gain_sigma": float(by["gain"][1]),
            "offset": float(by.get("offset", (0.0, 0.0))[0]), "offset_sigma": float(by.get("offset", (0.0, 0.0))[1]),
            "residual_rms": float(np.sqrt(np.mean(residual ** 2))),
            "residual_rms_relative": float(np.sqrt(np.mean(residual ** 2))) / d.signal_scale}


def _finish(problem: _Joint, x: np.ndarray, given: bool, orders: list[dict]) -> TemperatureFit:
    """Values, AR noises, covariance and the model file of the chosen joint fit."""
    bases, coefs, residuals = problem.project(x)
    noises = [fit_noise(r, rows_for(d), ar_order(d)) for r, d in zip(residuals, problem.records)]
    cov = problem.covariance(x, bases, coefs, noises)
    n_x = len(x)
    var = np.diag(cov) if cov is not None else np.full(n_x + sum(map(len, coefs)), np.nan)
    values = problem.values(x)
    sigmas = {p.name: _sd(p, values[p.name], var[j]) for j, p in enumerate(problem.params)}
    k_terms = problem.n_terms
    order = np.argsort([values[f"tau[{k}]"] for k in range(k_terms)])
    rename = {}
    for new, old in enumerate(order):
        for key in ("tau", "beta", "beta_per_kelvin"):
            rename[f"{key}[{old}]"] = f"{key}[{new}]"
    values = {rename.get(k, k): v for k, v in values.items()}
    sigmas = {rename.get(k, k): v for k, v in sigmas.items()}
    law_keys = ("activation_energy",) if problem.law == "arrhenius" else ("c1", "c2")
    unc = {k: sigmas[k] for k in law_keys}
    law_index = [j for j, p in enumerate(problem.params) if p.name in law_keys]
    if problem.law == "wlf" and cov is not None:
        i, j = law_index
        unc["c1_c2_correlation"] = float(cov[i, j] / math.sqrt(max(cov[i, i] * cov[j, j], 1e-300)))
    if problem.per_kelvin:
        unc["beta_per_kelvin"] = [sigmas[f"beta_per_kelvin[{k}]"] for k in range(k_terms)]
    law = _law_of(problem.law, problem.reference, values, k_terms, problem.per_kelvin, unc)
    records, start = [], n_x
    for r, d in enumerate(problem.records):
        n_lin = len(coefs[r])
        cov_lin = cov[start:start + n_lin, start:start + n_lin] if cov is not None else None
        start += n_lin
        shift_sd = _shift_sd(problem, x, cov, law_index, float(np.mean(problem.temperatures[r])))
        records.append(_record_summary(d, problem.temperatures[r], given, bases[r][1], coefs[r], cov_lin,
                                       residuals[r] * problem.scales[r], law, shift_sd))
        records[-1]["noise"] = ARNoise(noises[r].phi, noises[r].sigma * problem.scales[r]).to_dict(d.dt_median)
    ref = min(records, key=lambda rec: abs(rec["temperature_mean"] - problem.reference))
    model = CreepModel(tuple(values[f"beta[{k}]"] for k in range(k_terms)),
                       tuple(values[f"tau[{k}]"] for k in range(k_terms)), ref["gain"], ref["offset"], {}, law)
    bic, n_params = _bic(problem, x)
    return TemperatureFit(model, law, values, sigmas, tuple(records), bic, n_params, tuple(orders))


def _shift_sd(problem: _Joint, x: np.ndarray, cov, law_index: list[int], temperature: float) -> float:
    """Standard deviation of the shift factor at one temperature (delta method)."""
    if cov is None:
        return float("nan")
    grad = np.zeros(len(law_index))
    for i, j in enumerate(law_index):
        h = 1e-6 * max(1.0, abs(x[j]))
        xp, xm = x.copy(), x.copy()
        xp[j] += h
        xm[j] -= h
        lp = _law_of(problem.law, problem.reference, problem.values(xp), problem.n_terms, problem.per_kelvin)
        lm = _law_of(problem.law, problem.reference, problem.values(xm), problem.n_terms, problem.per_kelvin)
        grad[i] = float(lp.shift(temperature) - lm.shift(temperature)) / (2 * h)
    sub = cov[np.ix_(law_index, law_index)]
    return float(math.sqrt(max(float(grad @ sub @ grad), 0.0)))


def fit_temperature_law(records: Sequence[Data], law: str = "arrhenius",
                        temperatures: Sequence[float] | None = None, reference: float | None = None,
                        beta_per_kelvin: bool = False, n_terms: int | None = None,
                        max_terms: int = 6) -> TemperatureFit:
    """Fit one creep model and its temperature law to records at different temperatures.

    Parameters
    ----------
    records : sequence of Data
        Prepared records (:func:`creepcomp.fit.data.prepare`); one is enough when its
        temperature changes.
    law : {"arrhenius", "wlf"}
        The shift of the retardation times (WLF needs at least three temperatures).
    temperatures : sequence of float, optional
        One temperature (°C) per record, instead of their temperature columns.
    reference : float, optional
        Temperature (°C) at which the terms are stated (default :func:`default_reference`).
    beta_per_kelvin : bool
        Fit a linear change of each amplitude with temperature too.
    n_terms : int, optional
        Number of Prony terms. Default: the number :func:`creepcomp.fit.prony.fit_prony`
        chooses on the record nearest the reference, then one term fewer or more at a time
        while the joint fit's BIC on prewhitened residuals supports the change by
        :data:`~creepcomp.fit.evidence.BIC_STRONG`.
    max_terms : int

    Returns
    -------
    TemperatureFit

    Raises
    ------
    InputError
        A record without a temperature, temperatures that do not span a range, WLF with
        fewer than three temperatures.
    """
    records = list(records)
    if not records:
        raise InputError("no record to fit")
    if law not in LAWS:
        raise InputError(f"--law '{law}': use one of {', '.join(LAWS)}")
    if temperatures is not None and len(temperatures) != len(records):
        raise InputError(f"--temperature gives {len(temperatures)} temperatures for {len(records)} "
                         "records: give one per record")
    temps = [record_temperature(d, None if temperatures is None else temperatures[i])
             for i, d in enumerate(records)]
    every = np.concatenate(temps)
    if float(np.ptp(every)) <= 2 * CONSTANT_TEMPERATURE_TOLERANCE:
        raise InputError(f"the records' temperatures span {float(np.ptp(every)):.3g} K: a temperature law "
                         "needs records at different temperatures, or one whose temperature changes")
    if law == "wlf" and np.unique(np.round(every / (2 * CONSTANT_TEMPERATURE_TOLERANCE))).size < 3:
        raise InputError("a WLF law (c1, c2) needs records at three temperatures or more")
    ref = default_reference(temps) if reference is None else float(reference)
    if not math.isfinite(ref) or ref <= -ZERO_CELSIUS:
        raise InputError(f"--reference-temperature {ref:g} °C: must be above absolute zero")
    nearest = int(np.argmin([abs(float(np.mean(t)) - ref) for t in temps]))
    prony = fit_prony(records[nearest], max_terms=max_terms, n_terms=n_terms)
    k = prony.fit.structure.n_terms

    def order(n: int, starts=None) -> tuple:
        # an added term is refined from its best start only: most such terms are not supported
        n_refine = 3 if starts is None else 1
        if starts is None:
            starts = _record_starts(records, temps, ref, n, prony.steps[n - 1].fit)
        fits[n] = _fit_order(records, temps, law, ref, n, beta_per_kelvin, starts, n_refine)
        return fits[n]

    fits: dict[int, tuple] = {}
    deltas: dict[int, float] = {}
    order(k)
    if n_terms is None:
        # the record nearest the reference chose k; the joint fit may support fewer or more
        while k > 1:
            supported, deltas[k] = _supported(fits[k], order(k - 1))
            if supported:
                break
            k -= 1
        while k == max(fits) and k < max_terms:
            grid = tau_grid(records[nearest], per_decade=2)
            supported, deltas[k + 1] = _supported(order(k + 1, _added_term_starts(*fits[k], grid)), fits[k])
            if not supported:
                break
            k += 1
    orders = [{"n_terms": n, "bic": _bic(*fits[n])[0], "chosen": n == k,
               **({"delta_bic_whitened": deltas[n]} if n in deltas else {})} for n in sorted(fits)]
    return _finish(*fits[k], temperatures is not None, orders)
