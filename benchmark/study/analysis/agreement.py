"""Agreement between participants: Krippendorff's alpha (the ``krippendorff`` package).

Per question, the participants are the raters and the units are what several of them judged
alike (the same stimuli): A/B answers coded nominal (which row was chosen), MOS ratings
ordinal. Alpha is 1 when participants always agree, about 0 when they agree as often as
chance would, and below 0 when they disagree systematically. It is undefined (null) when no
unit was judged twice, or when every answer of a question is the same value.
"""

from __future__ import annotations

import krippendorff
import numpy as np


def agreement(judgements, level: str) -> dict:
    """``{question: {"alpha", "level", "raters", "units", "pairable_units"}}``."""
    out = {}
    for q, question in enumerate(judgements.questions):
        mask = judgements.question == q
        if not np.any(mask):
            continue
        raters, rater = np.unique(judgements.participant[mask], return_inverse=True)
        units, unit = np.unique(judgements.unit[mask], return_inverse=True)
        data = np.full((raters.size, units.size), np.nan)
        data[rater, unit] = judgements.value[mask]
        pairable = int(np.count_nonzero(np.sum(np.isfinite(data), axis=0) >= 2))
        alpha, note = None, None
        if pairable == 0:
            note = "no unit was judged by two participants"
        elif np.unique(judgements.value[mask]).size < 2:
            note = "every answer is the same value"
        else:
            alpha = float(krippendorff.alpha(reliability_data=data, level_of_measurement=level))
        out[question] = {"alpha": alpha, "level": level, "raters": int(raters.size), "units": int(units.size),
                         "pairable_units": pairable, **({"note": note} if note else {})}
    return out
