"""Pure model steps of the synthetic corpus: plan, audio, identity, regions, motion."""

import numpy as np
import pytest

from blendvoca.synthetic.audio import formant_filter, pitch_contour, resonator_response, speech_audio
from blendvoca.synthetic.identity import identity_displacement, speaker_profile
from blendvoca.synthetic.motion import animate_face, jaw_rotation_offsets
from blendvoca.synthetic.plan import sentence_plan
from blendvoca.synthetic.regions import face_regions
from blendvoca.synthetic.signals import motion_signals


@pytest.fixture(scope="module")
def flame(assets_dir):
    from blendvoca.io.mesh import read_ply, read_index_list

    V, F = read_ply(assets_dir / "voca" / "FLAME_sample.ply")
    return V, F, read_index_list(assets_dir / "said" / "FLAME_landmarks.txt")


def test_plan_fills_the_duration_with_realistic_syllable_rate():
    for seed in range(5):
        plan = sentence_plan(np.random.default_rng(seed), 4.0)
        assert plan.starts[0] == 0 and plan.ends[-1] == 4.0
        assert np.allclose(plan.starts[1:], plan.ends[:-1]) and np.all(plan.ends > plan.starts)
        assert plan.phones[0] == plan.phones[-1] == "_"
        rate = plan.num_syllables / 4.0
        assert 3.0 <= rate <= 7.0
    a, b = sentence_plan(np.random.default_rng(3), 3.5), sentence_plan(np.random.default_rng(3), 3.5)
    assert a.phones == b.phones and np.array_equal(a.ends, b.ends)
    with pytest.raises(ValueError, match="duration"):
        sentence_plan(np.random.default_rng(0), 0.5)


def _reference_resonators(x, formants, rate, bandwidths=(80.0, 110.0, 160.0)):
    """Direct-form recursion, one sample at a time: the independent reference."""
    y = np.asarray(x, dtype=np.float64)
    for f, bw in zip(formants, bandwidths):
        r = np.exp(-np.pi * bw / rate)
        c = 2 * r * np.cos(2 * np.pi * f / rate)
        out = np.zeros_like(y)
        y1 = y2 = 0.0
        for n, v in enumerate(y):
            out[n] = (1 - c + r * r) * v + c * y1 - r * r * y2
            y2, y1 = y1, out[n]
        y = out
    return y


def test_formant_filter_equals_the_recursive_filter_for_constant_formants():
    rate = 16000
    x = np.random.default_rng(0).standard_normal(3000)
    formants = (730.0, 1090.0, 2440.0)
    fast = formant_filter(x, np.tile(formants, (len(x), 1)), rate)
    ref = _reference_resonators(x, formants, rate)
    # Only the impulse-response truncation at nfft separates the two.
    assert np.max(np.abs(fast - ref)) < 1e-5 * np.max(np.abs(ref))


def test_resonator_peaks_at_the_formants():
    f = np.arange(0.0, 4000.0, 5.0)
    H = np.abs(resonator_response(np.array([[500.0, 1500.0, 2500.0]]), f, 22000))[0]
    peaks = f[1:-1][(H[1:-1] > H[:-2]) & (H[1:-1] > H[2:])]
    assert np.allclose(peaks, [500.0, 1500.0, 2500.0], atol=15.0)


def test_speech_audio_has_the_planned_pitch_and_length():
    rng = np.random.default_rng(1)
    plan = sentence_plan(rng, 3.0)
    audio = speech_audio(plan, rng, rate=16000, f0=120.0)
    assert audio.dtype == np.float32 and len(audio) == 48000
    assert np.max(np.abs(audio)) <= 0.61
    # Pitch of the longest vowel by autocorrelation, against the planned contour.
    v = int(np.argmax(np.where(plan.is_vowel(), plan.ends - plan.starts, 0)))
    a, b = int(plan.starts[v] * 16000), int(plan.ends[v] * 16000)
    seg = audio[a:b] - audio[a:b].mean()
    ac = np.correlate(seg, seg, "full")[len(seg) - 1:]
    lag = np.argmax(ac[16000 // 400: 16000 // 60]) + 16000 // 400
    times = (np.arange(a, b) / 16000.0)
    # The contour without its +-3 % random wander (drawn from another generator here).
    expected = np.mean(pitch_contour(plan, times, f0=120.0, rng=np.random.default_rng(99)))
    assert abs(16000 / lag - expected) / expected < 0.12
    # Silence at the margins is near the noise floor, speech is much louder.
    assert np.std(audio[:1600]) < 0.01 < np.std(audio[int(plan.ends[0] * 16000): int(plan.starts[-1] * 16000)])


def test_identity_is_smooth_centimetre_scale_and_deterministic(flame):
    V, F, _ = flame
    d = identity_displacement(V, np.random.default_rng(5))
    assert np.array_equal(d, identity_displacement(V, np.random.default_rng(5)))
    norms = np.linalg.norm(d, axis=1)
    assert 0.002 < norms.mean() < 0.015  # millimetres to a centimetre
    edges = np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]])
    edge_change = np.linalg.norm(d[edges[:, 0]] - d[edges[:, 1]], axis=1)
    edge_length = np.linalg.norm(V[edges[:, 0]] - V[edges[:, 1]], axis=1)
    assert np.max(edge_change / edge_length) < 0.5  # smooth: no edge stretched by half
    p = speaker_profile(np.random.default_rng(0))
    assert 90 <= p["f0"] <= 230 and 0.8 <= p["speaking_rate"] <= 1.2


def test_regions_follow_the_anatomy(flame):
    V, F, lm = flame
    R = face_regions(V, F, lm)
    assert np.all((R.jaw >= 0) & (R.jaw <= 1))
    assert R.jaw[lm[8]] > 0.95 and R.jaw[lm[57]] > 0.9 and R.jaw[lm[66]] > 0.9  # chin, lower lip
    assert R.jaw[lm[51]] < 0.1 and R.jaw[lm[62]] < 0.1 and R.jaw[lm[30]] < 0.01  # upper lip, nose
    assert 0.3 < R.jaw[lm[48]] < 0.7  # mouth corner blends
    assert R.lips[lm[62]] > 0.9 and R.lips[lm[30]] < 0.05
    assert R.upper_lid[lm[37]] > 0.5 and R.brows[lm[19]] > 0.9
    assert 0.005 < R.lid_gap < 0.012 and 0.04 < R.mouth_width < 0.065


def test_jaw_rotation_is_a_rotation_about_the_hinge_axis():
    rng = np.random.default_rng(0)
    V, hinge = rng.normal(size=(50, 3)), np.array([0.1, -0.2, 0.3])
    angles = np.array([0.0, 0.1, -0.3])
    moved = V[None] + jaw_rotation_offsets(V, hinge, angles)
    assert np.allclose(moved[0], V)
    for k, a in enumerate(angles):
        c, s = np.cos(a), np.sin(a)
        R = np.array([[1, 0, 0], [0, c, -s], [0, s, c]])
        assert np.allclose(moved[k], (V - hinge) @ R.T + hinge)


def test_motion_is_neutral_at_rest_and_the_jaw_opens_the_mouth(flame):
    V, F, lm = flame
    R = face_regions(V, F, lm)
    T = 4
    zero = {k: np.zeros(T) for k in ("jaw", "round", "closure", "labiodental", "blink", "brow")}
    assert np.array_equal(animate_face(V, R, zero), np.broadcast_to(V, (T, *V.shape)))
    opened = dict(zero, jaw=np.array([0.0, 0.5, 1.0, 1.0]))
    M = animate_face(V, R, opened)
    gap = M[:, lm[66], 1] - M[:, lm[62], 1]
    assert gap[0] > gap[1] > gap[2]  # the lower lip goes down
    assert np.allclose(M[:, lm[27]], V[lm[27]])  # the nose bridge does not move
    closed = dict(opened, closure=np.ones(T))
    gap_closed = animate_face(V, R, closed)[:, lm[66], 1] - animate_face(V, R, closed)[:, lm[62], 1]
    assert abs(gap_closed[2]) < abs(gap[2]) / 3  # closure holds the lips together
    with pytest.raises(ValueError, match="signals lack"):
        animate_face(V, R, {"jaw": np.zeros(T)})


def test_signals_are_shifted_by_the_lag():
    plan = sentence_plan(np.random.default_rng(2), 3.0)
    a = motion_signals(plan, 180, np.random.default_rng(0), lag_frames=0, jitter=0.0)
    b = motion_signals(plan, 180, np.random.default_rng(0), lag_frames=3, jitter=0.0)
    assert np.allclose(b["closure"][3:], a["closure"][:-3])
    assert np.allclose(b["envelope"], a["envelope"])  # the audio timeline does not move
