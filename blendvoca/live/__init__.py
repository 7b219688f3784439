"""Live output: a blendshape track sent to an engine frame by frame at its rate
(``python -m blendvoca.live``; docs/streaming.md, "Live output").

- :mod:`blendvoca.live.livelink_udp`: Live Link Face's UDP packet (Unreal's Live Link Face source), encode and decode;
- :mod:`blendvoca.live.osc`: OSC bundles, one message per ARKit shape (``/ARKit/<name>`` or the VMC protocol);
- :mod:`blendvoca.live.sender`: the ``--to`` address, the socket, the frame pacing on the monotonic clock;
- :mod:`blendvoca.live.sources`: the track, from a file or generated from a WAV by a method;
- :mod:`blendvoca.live.playback`: optional audio playback (sounddevice).
"""
