"""Model files and design files (``docs/design-file.md``): reading with checks, writing."""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from creepcomp.display import Shown, data_frame
from creepcomp.errors import InputError
from creepcomp.io.atomic import write_text_atomic
from creepcomp.io.inputs import MAX_JSON_BYTES, check_input_file
from creepcomp.active_stage import ActiveStage, is_active
from creepcomp.model import CreepModel
from creepcomp.network import Network

__all__ = ["read_json", "to_json", "write_json", "read_model", "write_model", "Design",
           "read_design", "write_design"]


def read_json(path: str | Path, what: str = "file") -> dict:
    """Read a JSON object, with one clear message for a missing, special (a pipe, a device),
    too large (:data:`~creepcomp.io.inputs.MAX_JSON_BYTES`) or malformed file."""
    p = Path(path)
    check_input_file(p, what, MAX_JSON_BYTES)
    try:
        text = p.read_text(encoding="utf-8-sig")
    except FileNotFoundError:
        raise InputError(f"{what} {p}: no such file") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"{what} {p}: cannot read it ({exc})") from None
    try:
        data = json.loads(text)
    except json.JSONDecodeError as exc:
        raise InputError(f"{what} {p}: not valid JSON at line {exc.lineno}, column {exc.colno}: "
                         f"{exc.msg}") from None
    except RecursionError:
        raise InputError(f"{what} {p}: nested too deeply to be a model or design file") from None
    except ValueError as exc:  # an integer of more digits than Python converts
        raise InputError(f"{what} {p}: a number in it cannot be read ({str(exc)[:80]})") from None
    if not isinstance(data, dict):
        raise InputError(f"{what} {p}: expected one JSON object, found {type(data).__name__}")
    return data


def _clean(obj: Any) -> Any:
    """JSON-safe copy: numpy scalars to floats, non-finite floats to None."""
    if isinstance(obj, dict):
        return {k: _clean(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_clean(v) for v in obj]
    if hasattr(obj, "item") and not isinstance(obj, (str, bytes)):
        obj = obj.item()
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    return obj


def to_json(obj: Any) -> str:
    """Serialise a result object to JSON text (non-finite numbers become null)."""
    return json.dumps(_clean(obj), indent=2, allow_nan=False)


def write_json(path: str | Path, obj: Any) -> Path:
    """Write a JSON object to ``path`` atomically (creating folders); returns the path."""
    p = Path(path)
    p.parent.mkdir(parents=True, exist_ok=True)
    return write_text_atomic(p, to_json(obj) + "\n")


def read_model(path: str | Path) -> CreepModel:
    """Read a model file (``beta``, ``tau`` ...) or the ``creep`` block of a design file."""
    data = read_json(path, "model file")
    if "creep" in data and "beta" not in data:
        return CreepModel.from_dict(data["creep"], where=f"model file {path}: 'creep'")
    return CreepModel.from_dict(data, where=f"model file {path}")


def write_model(path: str | Path, model: CreepModel) -> Path:
    """Write a model file."""
    return write_json(path, model.to_dict())


@dataclass(frozen=True)
class Design(Shown):
    """A design file: the creep it was sized for and the network that is built.

    Attributes
    ----------
    model : CreepModel
    network : Network
    extra : dict
        Keys beyond the contract (``rule``, ``series``, ``predicted`` ...), kept as read.
    """

    model: CreepModel
    network: Network
    extra: dict = field(default_factory=dict)

    def __repr__(self) -> str:
        from creepcomp.units import format_percent

        parts = self.network.parts()
        return (f"<Design {self.network.topology} network of {len(parts)} parts for "
                f"{self.model.n_terms} creep term{'s' if self.model.n_terms > 1 else ''} "
                f"(beta0 {format_percent(self.model.beta0)})>")

    def to_pandas(self):
        """The network's parts: label, kind (``R`` or ``C``) and value (Ω or F)."""
        parts = self.network.parts()
        return data_frame({"part": [p[0] for p in parts], "kind": [p[1] for p in parts],
                           "value": [p[2] for p in parts]})

    def to_dict(self) -> dict:
        """Design-file form."""
        out = {"creep": self.model.creep_block()}
        out.update(self.network.to_dict())
        out.update({k: v for k, v in self.extra.items() if k not in out})
        return out


def read_design(path: str | Path, active: bool = False) -> Design:
    """Read and check a design file.

    ``active``: accept the active stage (``topology`` ``"active"``,
    :class:`~creepcomp.active_stage.ActiveStage` as the design's network); without it such
    a file is refused by name, for the commands that take a passive network only.
    """
    data = read_json(path, "design file")
    where = f"design file {path}"
    if "creep" not in data:
        raise InputError(f"{where}: missing 'creep' (found keys: {', '.join(data)})")
    model = CreepModel.from_dict(data["creep"], where=f"{where}: 'creep'")
    topology = data.get("topology")
    if topology is not None and topology not in ("active", "lead", "lag"):
        raise InputError(f"{where}: topology {str(topology)[:40]!r}: use 'lead' (cells and R2), "
                         "'lag' (shunt branches) or 'active', or leave it out")
    if is_active(data):
        if not active:
            raise InputError(f"{where}: an active stage (topology 'active'); this command takes a "
                             "passive network (cells, R2): simulate, netlist and creep-test take "
                             "the active stage")
        stage = ActiveStage.from_dict(data, where=where)
        stage.check_buildable(where)
        known = {"creep", "topology", "active", "source_resistance", "load_resistance"}
        return Design(model, stage, {k: v for k, v in data.items() if k not in known})
    network = Network.from_dict(data, where=where)
    network.check_buildable(where)
    if topology is not None and topology != network.topology:
        raise InputError(f"{where}: topology '{topology}', but the network is a "
                         f"{network.topology} network ({'shunt branches' if network.shunt else 'no shunt branch'})")
    known = {"creep", "cells", "R2", "shunt", "source_resistance", "load_resistance"}
    return Design(model, network, {k: v for k, v in data.items() if k not in known})


def write_design(path: str | Path, design: Design | dict) -> Path:
    """Write a design file."""
    return write_json(path, design.to_dict() if isinstance(design, Design) else design)
