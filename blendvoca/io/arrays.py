"""Array arguments of the public entry points: any real dtype in, float64 out.

Callers hand in float32 meshes (VOCASET's processed layout, scanners), float16
tracks or integer test arrays; each public function converts with
:func:`float_array`, which raises a :class:`~blendvoca.errors.UserError` naming the
function, the argument and the expected shape when the value holds no real numbers
(strings, complex values, objects, ragged nested lists).
"""

from __future__ import annotations

import numpy as np

from blendvoca.errors import UserError

__all__ = ["float_array"]


def float_array(value, *, where: str, name: str, shape: str) -> np.ndarray:
    """``value`` as a C-contiguous float64 array.

    Parameters
    ----------
    value : array_like
        Real numbers of any dtype (float16/32/64, integers, bool).
    where : str
        The calling function (or file), for the message.
    name : str
        The argument, for the message.
    shape : str
        The expected shape as the message shows it, e.g. ``"(V, 3)"``; the caller
        checks the shape itself.

    Returns
    -------
    ndarray, float64
        A view when ``value`` already is one, else a converted copy.

    Raises
    ------
    UserError
        ``value`` does not convert to real numbers.
    """
    got = getattr(value, "dtype", type(value).__name__)
    try:
        complex_values = np.iscomplexobj(value)
        array = None if complex_values else np.ascontiguousarray(value, dtype=np.float64)
    except (TypeError, ValueError) as error:  # strings, objects, ragged nested lists
        raise UserError(f"{where}: expected {name} as a {shape} array of real numbers (any float or integer "
                        f"dtype), got {got} ({error})") from None
    if complex_values:
        raise UserError(f"{where}: expected {name} as a {shape} array of real numbers, got complex values ({got})")
    return array
