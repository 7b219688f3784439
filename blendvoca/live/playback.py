"""Optional audio playback beside the frames (``--play-audio``), through ``sounddevice``.

``sounddevice`` (PortAudio) is not a dependency of the project: it needs the system's
PortAudio library and a sound device, which servers and CI lack. Without it
``--play-audio`` is refused with the command that installs it.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from pathlib import Path

from blendvoca.errors import UserError

INSTALL = "pip install sounddevice  (and the system's PortAudio: apt install libportaudio2)"


def playback_starter(path) -> Callable[[], None]:
    """A function that starts playing the WAV ``path`` at once (non-blocking), the file read and the
    audio library loaded beforehand.

    Raises
    ------
    UserError
        No audio library, no such file, no output device.
    """
    try:
        import sounddevice
    except (ImportError, OSError) as error:  # OSError: the module is there, PortAudio is not
        raise UserError(f"--play-audio needs sounddevice ({error}); {INSTALL}; or leave --play-audio out") from None
    import soundfile

    path = Path(os.fspath(path)).expanduser()
    if not path.is_file():
        raise UserError(f"--audio {path}: no such file; expected the WAV to play")
    samples, rate = soundfile.read(path, dtype="float32", always_2d=True)
    try:
        sounddevice.check_output_settings(channels=samples.shape[1], samplerate=rate)
    except Exception as error:  # sounddevice.PortAudioError and ValueError: no device or format
        raise UserError(f"--play-audio: no output device plays {samples.shape[1]} channel(s) at {rate} Hz "
                        f"({error}); leave --play-audio out") from None

    def start() -> None:
        sounddevice.play(samples, rate)

    return start
