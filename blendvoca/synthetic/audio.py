"""Formant speech synthesis: a sentence plan rendered as a mono waveform.

Source-filter synthesis in pure numpy: a glottal flow pulse train with a
falling, stress-modulated pitch contour, passed through a cascade of three
time-varying formant resonators, plus band-limited noise for fricatives and
stop bursts. The time-varying filter is applied by short-time overlap-add: each
Hann-windowed block of the source is convolved (by zero-padded FFT, so
linearly) with the impulse response of the resonators at that block's formant
frequencies. Deterministic for a given random generator; no system dependency
(and no scipy.signal, whose import alone costs seconds).
"""

from __future__ import annotations

import numpy as np

from blendvoca.synthetic.phonetics import CONSONANTS
from blendvoca.synthetic.plan import SentencePlan
from blendvoca.synthetic.tracks import amplitude_track, formant_track, noise_track, segment_index

BANDWIDTHS = (80.0, 110.0, 160.0)  # Hz, of F1..F3


def pitch_contour(plan: SentencePlan, times: np.ndarray, *, f0: float, rng: np.random.Generator) -> np.ndarray:
    """Fundamental frequency in Hz, ``(N,) float64``.

    Declination from 1.12 f0 to 0.88 f0 over the sentence, +8 % on stressed
    syllables, and a slow random wander of a few percent.
    """
    if not 50.0 <= f0 <= 400.0:
        raise ValueError(f"pitch_contour: f0 must be in [50, 400] Hz, got {f0!r}")
    declination = 1.12 - 0.24 * times / max(plan.duration, 1e-9)
    seg = segment_index(plan, times)
    stress = np.where(plan.stress[seg] > 1.0, 1.08, 1.0)
    knots = np.linspace(0.0, plan.duration, max(4, int(plan.duration * 4)))
    wander = 1.0 + 0.03 * np.interp(times, knots, rng.standard_normal(len(knots)))
    return f0 * declination * stress * wander


def glottal_source(f0_track: np.ndarray, rate: int, *, open_quotient: float = 0.6) -> np.ndarray:
    """Differentiated glottal flow (radiated source), ``(N,) float64``.

    The flow is a raised-sine pulse over the open phase of each cycle; its time
    derivative gives the -6 dB/octave tilt of real voiced speech after radiation.
    """
    phase = np.cumsum(f0_track / rate) % 1.0
    flow = np.where(phase < open_quotient, np.sin(np.pi * phase / open_quotient) ** 2, 0.0)
    return np.diff(flow, prepend=0.0) * (rate / np.mean(f0_track)) * 0.05


def resonator_response(formants: np.ndarray, freqs: np.ndarray, rate: int,
                       bandwidths: tuple[float, ...] = BANDWIDTHS) -> np.ndarray:
    """Complex frequency response of cascaded two-pole resonators (unit gain at DC).

    Parameters
    ----------
    formants : (B, K) ndarray
        Centre frequencies in Hz of K resonators for B blocks.
    freqs : (M,) ndarray
        Frequencies in Hz at which to evaluate.

    Returns
    -------
    (B, M) complex ndarray
    """
    z1 = np.exp(-2j * np.pi * freqs / rate)[None, :]
    H = np.ones((len(formants), len(freqs)), dtype=np.complex128)
    for k, bw in enumerate(bandwidths[: formants.shape[1]]):
        r = np.exp(-np.pi * bw / rate)
        c = (2.0 * r * np.cos(2.0 * np.pi * np.minimum(formants[:, k], 0.95 * rate / 2) / rate))[:, None]
        H *= (1.0 - c + r * r) / (1.0 - c * z1 + r * r * z1 * z1)
    return H


def formant_filter(source: np.ndarray, formants: np.ndarray, rate: int, *, hop: int = 128,
                   nfft: int = 1024, bandwidths: tuple[float, float, float] = BANDWIDTHS) -> np.ndarray:
    """Cascade of second-order resonators with time-varying centre frequencies.

    Short-time overlap-add with a periodic Hann window of ``2 * hop`` samples
    (which sums to one at 50 % overlap) and zero-padded FFT convolution, so each
    block is filtered linearly with the resonators of its centre.

    Parameters
    ----------
    source : (N,) ndarray
    formants : (N, 3) ndarray
        F1..F3 in Hz per sample (taken at each block's centre).
    rate : int
        Sample rate in Hz.

    Returns
    -------
    (N,) ndarray
    """
    x = np.asarray(source, dtype=np.float64)
    n = len(x)
    win = 2 * hop
    window = 0.5 - 0.5 * np.cos(2.0 * np.pi * np.arange(win) / win)
    starts = np.arange(-hop, n, hop)
    padded = np.concatenate([np.zeros(hop), x, np.zeros(win + nfft)])
    blocks = np.stack([padded[s + hop: s + hop + win] for s in starts]) * window
    centres = np.clip(starts + hop, 0, n - 1)
    H = resonator_response(np.asarray(formants)[centres], np.fft.rfftfreq(nfft, 1.0 / rate), rate, bandwidths)
    filtered = np.fft.irfft(np.fft.rfft(blocks, nfft, axis=1) * H, nfft, axis=1)
    out = np.zeros(n + hop + nfft + win)
    for b, s in enumerate(starts):
        out[s + hop: s + hop + nfft] += filtered[b]
    return out[hop: hop + n]


def band_noise(rng: np.random.Generator, length: int, low: float, high: float, rate: int) -> np.ndarray:
    """White noise band-limited to ``[low, high]`` Hz (raised-cosine edges), unit RMS, ``(length,)``."""
    nfft = int(2 ** np.ceil(np.log2(max(length, 2))))
    spectrum = np.fft.rfft(rng.standard_normal(nfft))
    f = np.fft.rfftfreq(nfft, 1.0 / rate)
    edge = 0.15 * (high - low)
    mask = np.clip(np.minimum((f - low) / edge + 0.5, (high - f) / edge + 0.5), 0.0, 1.0)
    mask = 0.5 - 0.5 * np.cos(np.pi * mask)
    band = np.fft.irfft(spectrum * mask, nfft)[:length]
    return band / (np.sqrt(np.mean(band**2)) + 1e-12)


def frication_noise(plan: SentencePlan, rate: int, num_samples: int, rng: np.random.Generator) -> np.ndarray:
    """Noise band-passed per consonant to its noise band, ``(N,) float64`` (unit level)."""
    noise = np.zeros(num_samples)
    pad = int(0.01 * rate)
    for i, p in enumerate(plan.phones):
        c = CONSONANTS.get(p)
        if c is None or c["noise"] is None:
            continue
        low, high, _ = c["noise"]
        a0 = max(int(plan.starts[i] * rate) - pad, 0)
        b = min(int(np.ceil(plan.ends[i] * rate)) + pad, num_samples)
        if b > a0:
            noise[a0:b] += band_noise(rng, b - a0, low, min(high, 0.95 * rate / 2), rate)
    return noise


def speech_audio(
    plan: SentencePlan,
    rng: np.random.Generator,
    *,
    rate: int = 22000,
    f0: float = 120.0,
    formant_scale: float = 1.0,
    peak: float = 0.6,
    noise_floor: float = 3e-4,
) -> np.ndarray:
    """Synthesise one sentence, ``(N,) float32`` with ``N = round(duration * rate)``.

    Parameters
    ----------
    plan : SentencePlan
    rng : numpy.random.Generator
        Pitch wander, frication noise and the recording noise floor.
    rate : int
        Sample rate in Hz (VOCASET's audio is 22 kHz).
    f0 : float
        Speaker's mean pitch in Hz.
    formant_scale : float
        Vocal-tract-length factor applied to all formants.
    peak : float
        Peak absolute amplitude after normalisation.
    noise_floor : float
        RMS of the added background noise (recordings are never digital zero).
    """
    if rate < 8000:
        raise ValueError(f"speech_audio: rate must be at least 8000 Hz, got {rate!r}")
    n = int(round(plan.duration * rate))
    times = np.arange(n, dtype=np.float64) / rate
    voiced = glottal_source(pitch_contour(plan, times, f0=f0, rng=rng), rate)
    voiced = formant_filter(voiced, formant_track(plan, times, scale=formant_scale), rate)
    voiced *= amplitude_track(plan, times) / (np.sqrt(np.mean(voiced**2)) + 1e-12)
    noise = frication_noise(plan, rate, n, rng) * noise_track(plan, times)
    signal = voiced + 0.5 * noise
    signal *= peak / (np.max(np.abs(signal)) + 1e-12)
    signal += noise_floor * rng.standard_normal(n)
    return np.clip(signal, -1.0, 1.0).astype(np.float32)
