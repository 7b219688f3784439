"""OSC frames (python-osc): one bundle per frame, one message per ARKit shape.

Two address styles (``--osc-style``):

``arkit`` (default)
    ``<prefix>/<name> ,f <value>`` per shape, the prefix ``/ARKit`` unless told
    (``--osc-prefix``): the ARKit name is the address, for receivers that bind one
    parameter per address (Unity or Godot OSC receivers, TouchDesigner, VRChat-style
    ``/avatar/parameters`` with ``--osc-prefix /avatar/parameters``).
``vmc``
    the VMC protocol's blendshape messages, ``/VMC/Ext/Blend/Val ,sf <name> <value>``
    per shape then ``/VMC/Ext/Blend/Apply``, as VSeeFace, VirtualMotionCapture and
    EVMC4U receive them (perfect-sync models name their clips after the ARKit shapes;
    their default port is 39539).

Names are ARKit's camelCase (``jawOpen``), or PascalCase (``JawOpen``) with
``case="pascal"``. Values are OSC float32. A bundle carries the immediate time tag, so
the receiver applies a frame when it arrives.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from blendvoca.errors import UserError
from blendvoca.names import ARKIT_FACE_ORDER, arkit_name, pascal_name

#: ``--osc-style`` values.
STYLES = ("arkit", "vmc")
#: ``--osc-case`` values.
CASES = ("camel", "pascal")
#: The default address prefix of the ``arkit`` style.
DEFAULT_PREFIX = "/ARKit"
#: The VMC protocol's blendshape value and apply addresses.
VMC_VALUE, VMC_APPLY = "/VMC/Ext/Blend/Val", "/VMC/Ext/Blend/Apply"
#: The VMC protocol's default receiving port (VSeeFace, VirtualMotionCapture).
VMC_PORT = 39539

INSTALL = "pip install 'blendvoca[live]'  (python-osc)"


def _pythonosc():
    try:
        from pythonosc import osc_bundle_builder, osc_message_builder
    except ImportError:
        raise UserError(f"OSC output needs python-osc: {INSTALL}") from None
    return osc_bundle_builder, osc_message_builder


def osc_names(names: Sequence[str], case: str = "camel") -> tuple[str, ...]:
    """The spelling of each track name on the wire.

    Raises
    ------
    UserError
        A name that is no ARKit shape (each named), an unknown ``case``.
    """
    if case not in CASES:
        raise UserError(f"--osc-case: expected one of {', '.join(CASES)}, got {case!r}")
    unknown = [n for n in names if arkit_name(n) is None]
    if unknown:
        raise UserError(f"OSC output sends ARKit shapes by name and {unknown} are none; expected ARKit's 52 "
                        f"({', '.join(ARKIT_FACE_ORDER[:3])}, ...) in any case")
    return tuple(arkit_name(n) if case == "camel" else pascal_name(n) for n in names)


def check_prefix(prefix: str) -> str:
    """``prefix`` without a trailing slash; a UserError unless it starts with ``/`` and holds no OSC
    pattern characters or spaces."""
    text = str(prefix).rstrip("/")
    bad = set(text) & set(" #*,?[]{}")
    if not str(prefix).startswith("/") or bad:
        raise UserError(f"--osc-prefix {prefix!r}: expected an OSC address such as /ARKit (starting with '/', "
                        "without spaces or any of # * , ? [ ] { })")
    return text


def frame_bundle(values, names: Sequence[str], *, style: str = "arkit", prefix: str = DEFAULT_PREFIX) -> bytes:
    """The datagram of one frame: an OSC bundle of one message per name (``names`` as they go on the
    wire, :func:`osc_names`), then ``/VMC/Ext/Blend/Apply`` in the ``vmc`` style."""
    if style not in STYLES:
        raise UserError(f"--osc-style: expected one of {', '.join(STYLES)}, got {style!r}")
    bundle_builder, message_builder = _pythonosc()
    values = np.asarray(values, dtype=np.float64)
    bundle = bundle_builder.OscBundleBuilder(bundle_builder.IMMEDIATELY)
    for name, value in zip(names, values.tolist()):
        if style == "arkit":
            message = message_builder.OscMessageBuilder(address=f"{prefix}/{name}")
        else:
            message = message_builder.OscMessageBuilder(address=VMC_VALUE)
            message.add_arg(name, "s")
        message.add_arg(value, "f")
        bundle.add_content(message.build())
    if style == "vmc":
        bundle.add_content(message_builder.OscMessageBuilder(address=VMC_APPLY).build())
    return bundle.build().dgram
