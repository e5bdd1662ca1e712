"""The model a diagnosis recommends: the one that gives the load back, and that `correct` takes.

A diagnosis extends the paper's model (linear creep, a signal linear in load) by effects
judged on the signal. What a user needs back is the load. A soft sensor's signal is far from
linear in load, and there the family of :mod:`creepcomp.fit.signal_path` (static maps around
linear creep, down to a static calibration) may give the load back better than any extension
of a linear model. So the recommendation puts every member on one footing: each is fitted on
the first part of the record (the extended model's structure refitted there too) and judged
by its RMS load error on the held-out rest; the rule of :func:`creepcomp.fit.signal_path.choose`
picks one (a member with more parts must win by its margin). The model written is that
member fitted on the whole record: the diagnosis's own extended or baseline model for those
members, the signal-path fit otherwise.

Every model recommended is one the creep correction and the firmware accept (:func:`usable`):
where the chosen one is not, the next in the order is taken and the refusal said.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from creepcomp.display import Shown
from creepcomp.errors import InputError

__all__ = ["Recommendation", "recommend", "usable", "model_load", "refit_structure", "EXTENDED",
           "MAPPED_EXTENDED"]

#: Name of the diagnosis's extended model among the members.
EXTENDED = "extended (diagnosis)"
#: Name of the member that diagnoses effects in the linear domain of the chosen static maps.
MAPPED_EXTENDED = "extended on the static maps (diagnosis)"


@dataclass(frozen=True, eq=False)
class Recommendation(Shown):
    """The recommended model and why.

    Attributes
    ----------
    which : str
        ``signal path`` (a static calibration, or static maps around creep), ``extended`` or
        ``baseline``.
    model : dict
        Its model file.
    reason : str
        One sentence with the figures behind the choice.
    chosen : str
        The member chosen by held-out load error.
    candidates : tuple of Candidate
        Every member, with its held-out load error (empty where the family could not be
        fitted).
    load_range : float
        The record's load range, the scale of the errors.
    split_time : float or None
        Where the held-out part starts (s).
    refused : dict
        Why a model higher in the order was not taken, by name.
    """

    which: str
    model: dict
    reason: str
    chosen: str
    candidates: tuple
    load_range: float
    split_time: float | None
    refused: dict

    def __repr__(self) -> str:
        return f"<Recommendation the {self.which} model: {self.chosen}>"

    def to_dict(self) -> dict:
        """JSON form (``recommended`` in a diagnosis's JSON)."""
        return {"which": self.which, "reason": self.reason, "chosen": self.chosen,
                "load_range": self.load_range, "split_time": self.split_time,
                "candidates": [c.to_dict() for c in self.candidates], "refused": dict(self.refused)}


def usable(model_file: dict, firmware: bool = False) -> str | None:
    """Why the creep correction would refuse this model file, or None when it takes it.

    ``firmware``: also why ``creepcomp firmware`` would refuse it for what the model is (an
    extension it has no C for, static maps together with an extension or a temperature law);
    the sample rate and the input range it is given are checked when it runs.
    """
    from creepcomp.digital.correctors import check_invertible
    from creepcomp.model import CreepModel

    try:
        model = CreepModel.from_dict(model_file)
        check_invertible(model)
        if model.extensions:
            from creepcomp.diagnose.effects import extension_inverses, firmware_output

            extension_inverses(model)
            if firmware:
                firmware_output(model)
        if firmware and model.transfer is not None and (model.extensions or model.temperature):
            raise InputError("firmware: the C corrector has no static maps together with "
                             + ("an extension" if model.extensions else "a temperature law"))
        if firmware and model.load_filter is not None and (model.extensions or model.temperature):
            raise InputError("firmware: the C corrector has no load filter together with "
                             + ("an extension" if model.extensions else "a temperature law"))
    except InputError as exc:
        return str(exc)
    return None


def model_load(model, time, signal, temperature=None) -> np.ndarray:
    """The load a model gives back from a signal: its whole inverse, static maps and fitted
    extensions included (a model without extensions: :func:`creepcomp.digital.correctors.estimate_load`).

    Parameters
    ----------
    model : CreepModel
    time, signal : array_like
    temperature : array_like, optional
        For a model with a temperature law or thermal extensions.

    Returns
    -------
    numpy.ndarray
        The load estimate in load units.

    Examples
    --------
    >>> import numpy as np
    >>> from creepcomp.model import CreepModel
    >>> from creepcomp.diagnose.recommend import model_load
    >>> model = CreepModel((0.05,), (10.0,), gain=2.0, offset=0.1)
    >>> t = np.arange(0.0, 100.0, 0.5)
    >>> load = np.where(t >= 10, 3.0, 0.0)
    >>> bool(np.allclose(model_load(model, t, model.response(t, load, hold="zero")), load))
    True
    """
    from creepcomp.digital.correctors import estimate_load, filter_load, load_from_linear

    if not model.extensions:
        return estimate_load(time, signal, model, temperature=temperature)
    from creepcomp.diagnose.effects import compensate_extended

    x = np.asarray(signal, float) if model.transfer is None else model.transfer.linearise_within(signal)
    return filter_load(load_from_linear(compensate_extended(time, x, model, temperature, converge=True), model),
                       model, time)


def _percent(x: float) -> str:
    return f"{100 * x:.3g} %" if math.isfinite(x) else "-"


def _mapped(record, transfer, mask=None):
    """The record in the linear domain of the maps (``f(load)``, ``h(signal)``; a part of it),
    or the record itself without maps."""
    from creepcomp.io.records import Record

    m = slice(None) if mask is None else mask
    if transfer is None:
        load, signal = record.load[m], record.signal[m]
    else:
        load = transfer.load_in(record.load[m])
        signal = transfer.linearise_within(record.signal[m])
    return Record(record.time[m], load, signal,
                  temperature=None if record.temperature is None else record.temperature[m],
                  source=record.source)


def refit_structure(record, model, mask=None) -> dict:
    """A model's structure (terms, extensions, static maps) fitted again on a record, or a
    part of it: the model file of the refit.

    Parameters
    ----------
    record : Record
    model : CreepModel
        The model whose structure is refitted (its values are the start).
    mask : numpy.ndarray of bool, optional
        The samples to fit (default: all).
    """
    from creepcomp.diagnose.effects import model_structure
    from creepcomp.fit.data import prepare
    from creepcomp.fit.prony import model_file_dict
    from creepcomp.fit.solver import fit_structure
    from creepcomp.model import CreepModel

    transfer = model.transfer
    linear = CreepModel(model.beta, model.tau, model.gain, model.offset, dict(model.extensions))
    data = prepare(_mapped(record, transfer, mask))
    structure, values = model_structure(linear, data)
    refit = model_file_dict(data, fit_structure(data, structure, [values]))
    return refit if transfer is None else {**refit, "transfer": transfer.to_dict()}


def _windows(record, path) -> list[tuple[np.ndarray, np.ndarray]]:
    """The two (fitted, judged) windows of the signal path (:mod:`creepcomp.fit.signal_path`):
    fitted on the first half, judged on the next quarter; fitted on the first three quarters,
    judged on the last."""
    from creepcomp.fit.signal_path import VALIDATION

    t = record.time
    late = t < path.split_time
    early_cut = t[0] + (1.0 - 2.0 * VALIDATION) / (1.0 - VALIDATION) * (path.split_time - t[0])
    early = t < early_cut
    return [(early, late & ~early), (late, ~late)]


def _member(name: str, model, parts: int, record, path):
    """A member judged as the signal path's are: its structure refitted on each window's first
    part and judged on the next; the score the worse of the two."""
    from creepcomp.fit.signal_path import Candidate, held_out_load_rms, window_score
    from creepcomp.model import CreepModel

    try:
        scores, refit = [], None
        for fitted, judged in _windows(record, path):
            refit = CreepModel.from_dict(refit_structure(record, model, fitted))
            upto = fitted | judged
            with np.errstate(all="ignore"):
                estimate = model_load(refit, record.time[upto], record.signal[upto],
                                      None if record.temperature is None else record.temperature[upto])
            scores.append(held_out_load_rms(estimate, _mapped(record, None, upto), judged[upto],
                                            path.load_range))
        # the later window's refit stands for the member (as the signal path's members do)
        return Candidate(name, refit, window_score(scores), parts, windows=tuple(scores))
    except (InputError, ValueError, np.linalg.LinAlgError) as exc:
        return Candidate(name, None, math.inf, parts, str(exc).splitlines()[0][:200])


def _extended_member(record, diagnosis, path):
    """The diagnosis's extended model as a member (None without extensions: then it is the
    baseline's structure, a member already)."""
    from creepcomp.model import CreepModel

    extensions = diagnosis.extended_model.get("extensions") or {}
    if not extensions:
        return None
    try:
        model = CreepModel.from_dict(diagnosis.extended_model)
    except InputError as exc:
        from creepcomp.fit.signal_path import Candidate

        return Candidate(EXTENDED, None, math.inf, len(extensions) + 1, str(exc))
    return _member(EXTENDED, model, model.n_terms + len(extensions), record, path)


def _mapped_extended_member(record, path, jobs: int = 1):
    """Effects diagnosed in the linear domain of the signal path's chosen maps (a soft
    sensor's memory on top of its nonlinear transfer), as a member: the diagnosis of the mapped
    record's later fitted part gives the structure. None when the chosen member has no maps or
    no effect is found there."""
    from creepcomp.diagnose.sensor import diagnose
    from creepcomp.fit.signal_path import Candidate
    from creepcomp.model import CreepModel

    chosen = path.candidate(path.chosen)
    transfer = None if chosen.model is None else chosen.model.transfer
    if transfer is None or chosen.model.is_static:
        return None
    try:
        with np.errstate(all="ignore"):
            found = diagnose(_mapped(record, transfer, record.time < path.split_time),
                             correction=False, jobs=jobs)
        extended = found.extended_model
        if not extended.get("extensions"):
            return None
        model = CreepModel.from_dict({**extended, "transfer": transfer.to_dict()})
    except (InputError, ValueError, np.linalg.LinAlgError) as exc:
        return Candidate(MAPPED_EXTENDED, None, math.inf, chosen.parts + 1, str(exc).splitlines()[0][:200])
    return _member(MAPPED_EXTENDED, model, chosen.parts + len(extended["extensions"]), record, path)


def recommend(record, diagnosis, signal_path: bool = True) -> Recommendation:
    """Choose the model to write as ``model.json`` for a diagnosed record.

    Parameters
    ----------
    record : Record
        The record the diagnosis was made on.
    diagnosis : Diagnosis
        Its result (:func:`creepcomp.diagnose.sensor.diagnose`).
    signal_path : bool
        Judge the members by held-out load error (False: the extended model, or the
        baseline where the correction cannot invert it).

    Returns
    -------
    Recommendation

    Examples
    --------
    The bundled force sensor recovers more slowly than it creeps: the extended model gives
    its load back best.

    >>> from creepcomp.data import hidden_effect
    >>> from creepcomp.diagnose.sensor import diagnose
    >>> from creepcomp.diagnose.recommend import recommend
    >>> record = hidden_effect()
    >>> rec = recommend(record, diagnose(record))
    >>> rec.which, rec.chosen
    ('extended', 'extended (diagnosis)')
    """
    from creepcomp.fit.signal_path import choose, fit_signal_path

    refused, path = {}, None
    if signal_path:
        try:
            path = fit_signal_path(record)
        except InputError as exc:
            refused["signal path"] = str(exc)
    members = list(path.candidates) if path is not None else []
    if path is not None:
        for extended in (_extended_member(record, diagnosis, path), _mapped_extended_member(record, path)):
            if extended is not None:
                members.append(extended)
    order = []
    if members:
        chosen = choose(members)
        order.append(chosen)
        order += sorted((c for c in members if c is not chosen and c.model is not None),
                        key=lambda c: c.heldout_load_rms)
    load_range = path.load_range if path is not None else float(np.ptp(record.load))
    split = path.split_time if path is not None else None
    versus = _versus(members)
    for member in order or [None]:
        which, model = _model_of(member, diagnosis, path, record)
        filtered = _with_load_filter(model, member, path)
        if filtered is not None and usable(filtered, firmware=True) is None:
            model = filtered
        why = usable(model, firmware=True)
        if why is None:
            name = member.name if member is not None else which
            reason = (f"{name} gives the load back with {_percent(member.heldout_load_rms)} RMS error "
                      f"of the load range on the held-out last part of the record"
                      f"{_filtered(model, path)}{versus}"
                      if member is not None else f"the {which} model (the load error was not measured)")
            return Recommendation(which, model, reason, name, tuple(members), load_range, split, refused)
        refused[member.name if member is not None else which] = why
    for which, model in (("extended", diagnosis.extended_model), ("baseline", diagnosis.baseline_model)):
        if usable(model, firmware=True) is None:
            return Recommendation(which, model, f"the {which} model: no better member can be inverted",
                                  which, tuple(members), load_range, split, refused)
    raise InputError("no model of this record can be inverted by the creep correction: "
                     + "; ".join(f"{k}: {v}" for k, v in refused.items()))


def _model_of(member, diagnosis, path, record) -> tuple[str, dict]:
    """The model file written for a member: fitted on the whole record."""
    if member is None or (member.name == EXTENDED):
        return "extended", diagnosis.extended_model
    if member.name == MAPPED_EXTENDED:
        try:
            return "signal path", refit_structure(record, member.model)
        except (InputError, ValueError, np.linalg.LinAlgError):
            return "signal path", member.model.to_dict()
    if member.name.startswith("linear creep") and not diagnosis.extended_model.get("extensions"):
        return "extended", diagnosis.extended_model
    if member.name.startswith("linear creep"):
        return "baseline", diagnosis.baseline_model
    if member.name == path.chosen:
        return "signal path", path.model.to_dict()
    return "signal path", member.model.to_dict()


def _with_load_filter(model: dict, member, path) -> dict | None:
    """The model file with the signal path's load filter, where the member is the path's
    chosen one (the filter was chosen for it) and the model has neither extensions nor a
    temperature law; None otherwise."""
    if (member is None or path is None or member.name != path.chosen or path.model.load_filter is None
            or model.get("extensions") or model.get("temperature")):
        return None
    return {**model, "load_filter": path.model.load_filter.to_dict()}


def _filtered(model: dict, path) -> str:
    """The held-out error with the load filter, where the model has one."""
    if not model.get("load_filter") or path is None:
        return ""
    return (f"; with {path.model.load_filter.describe()}, chosen on the same windows, "
            f"{_percent(path.filtered_load_rms)}")


def _versus(members) -> str:
    """The figures of the plain references beside the chosen member's."""
    out = []
    for c in members:
        if c.model is None or not math.isfinite(c.heldout_load_rms):
            continue
        if c.name in ("static line", "static monotone", EXTENDED, MAPPED_EXTENDED) or c.name.startswith("linear creep"):
            out.append(f"{c.name} {_percent(c.heldout_load_rms)}")
    return ("; " + ", ".join(out)) if out else ""
