"""What both generators share: their measurement noise, and the rules that keep a hidden effect
or fault visible in it (in held-out ``z`` with every parameter known)."""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from creepcomp.fit.noise import spectral_variance

__all__ = ["DETECTABLE_Z", "DISTINCT_Z", "PRECISE_TO", "NoiseSpec", "sample_noise", "scaled_noise",
           "heldout_z"]

#: Randomised records keep a hidden effect detectable: where its signature, beyond what the
#: baseline absorbs, would stand less than this far out of the noise
#: (:func:`~creepcomp.synth.sensor.detectability`, in held-out z with every parameter known;
#: diagnose asks for 3 with them fitted), the record's noise is scaled down until it does.
DETECTABLE_Z = 10.0
#: Held-out ``z`` that the part of a benchmark record's circuit fault no other circuit fault
#: mimics must reach at least (:func:`~creepcomp.synth.circuit.alternative_faults`): the fault
#: can be told apart.
DISTINCT_Z = 5.0
#: Relative 1-sigma uncertainty to which a benchmark record of a built network determines its
#: fault's parts (C, R) at most: "within 10 %" is then three standard deviations.
PRECISE_TO = 0.03


@dataclass(frozen=True)
class NoiseSpec:
    """Measurement noise a generator adds, in signal units.

    Attributes
    ----------
    white : float
        Standard deviation of white noise.
    coloured : float
        Standard deviation of an Ornstein-Uhlenbeck (continuous AR(1)) component.
    correlation_time : float
        Its correlation time (s).
    drift : float
        Random-walk drift: standard deviation after one hour.
    lsb : float
        Quantisation step (0: none).
    """

    white: float = 1e-3
    coloured: float = 0.0
    correlation_time: float = 1.0
    drift: float = 0.0
    lsb: float = 0.0


def sample_noise(t: np.ndarray, noise: NoiseSpec, rng: np.random.Generator) -> np.ndarray:
    """A realisation of ``noise`` at the times ``t`` (s): white, coloured and drift components
    (quantisation is the generator's, on the noisy signal)."""
    e = rng.normal(0.0, noise.white, len(t)) if noise.white > 0 else np.zeros(len(t))
    if noise.coloured > 0:
        a = np.exp(-np.diff(t) / noise.correlation_time)
        x = np.empty(len(t))
        x[0] = rng.normal(0, noise.coloured)
        w = rng.normal(0, 1, len(t) - 1) * noise.coloured * np.sqrt(1 - a ** 2)
        for i in range(1, len(t)):
            x[i] = a[i - 1] * x[i - 1] + w[i - 1]
        e = e + x
    if noise.drift > 0:
        steps = rng.normal(0, 1, len(t) - 1) * noise.drift * np.sqrt(np.diff(t) / 3600.0)
        e = e + np.concatenate([[0.0], np.cumsum(steps)])
    return e


def scaled_noise(noise: NoiseSpec, f: float) -> NoiseSpec:
    """The noise with every component scaled by ``f``."""
    return replace(noise, white=noise.white * f, coloured=noise.coloured * f, drift=noise.drift * f,
                   lsb=noise.lsb * f)


def heldout_z(rest: np.ndarray, noise: np.ndarray) -> float:
    """Held-out ``z`` of a signature with every parameter known: its energy over twice the
    spread of its product with the noise (spectrum from ``noise``)."""
    spread = math.sqrt(max(spectral_variance(rest, noise), 0.0))
    return float(np.sum(rest ** 2) / (2.0 * spread)) if spread > 0 else math.inf

