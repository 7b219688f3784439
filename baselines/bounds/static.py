"""``static``: the neutral face, all coefficients zero (lower reference)."""

from __future__ import annotations

import numpy as np

from benchmark.methods.base import Method

__all__ = ["StaticMethod"]


class StaticMethod(Method):
    """Lower reference: the speaker's neutral face for every frame (all zeros).

    Parameters
    ----------
    num_coeffs : int
        Number of coefficients (32).
    """

    name = "static"
    stochastic = False
    reference = True

    def __init__(self, num_coeffs: int = 32):
        super().__init__(num_coeffs=num_coeffs)

    def generate(self, utterance, *, samples=1, seed=0):
        return np.zeros((int(samples), utterance.num_frames, int(self._config["num_coeffs"])))
