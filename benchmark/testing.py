"""Test kit for method plug-ins: :func:`check_method` and the small in-memory
:class:`FakeBlendVOCA` dataset it trains on.

A plug-in's own test suite needs one line::

    from benchmark.testing import check_method
    check_method(MyMethod, some_option=3)

``check_method`` builds the method, checks the config round trip, trains it
briefly on a fake dataset (coefficient tracks, audio whose loudness follows the jaw,
a rig, source vertices, template and faces), generates through the runner's own
code path (so the runner's shape, range and finiteness checks apply, for both
output kinds), checks that the same seed gives the same output, saves, loads and
compares, and raises :class:`MethodCheckError` naming the step that failed.
"""

from __future__ import annotations

import contextlib
import json
import tempfile
import traceback
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from benchmark.methods.base import Budget, Method
from benchmark.methods.request import TrainingRequest, call_train
from benchmark.methods.contract import AUDIO_RATE, COEFFICIENT_NAMES, FPS, OUTPUT_KINDS, Utterance
from benchmark.protocol import generated_tracks
from blendvoca.runtime.progress import progress_bars

__all__ = ["RANDOM_RIG_EXTRA_SHAPE", "RANDOM_RIG_VERTICES", "CheckReport", "FakeBlendVOCA", "MethodCheckError",
           "check_method"]


class MethodCheckError(AssertionError):
    """A plug-in broke the method contract; the message names the step and what was expected."""


def _head_mesh(subdivisions: int = 3):
    """An ellipsoid head ~20 cm tall (metres), ``(V, 3)`` vertices and ``(F, 3)`` faces; +z is the front."""
    import trimesh

    sphere = trimesh.creation.icosphere(subdivisions=subdivisions, radius=1.0)
    vertices = np.asarray(sphere.vertices, dtype=np.float64) * np.array([0.075, 0.1, 0.09])
    return vertices, np.asarray(sphere.faces, dtype=np.int64)


def _fake_rig(neutral, faces, rng):
    """32 localized smooth shapes: mouth shapes around the mouth, cheek/nose shapes on cheeks and nose."""
    from blendvoca.rig import Rig

    front = neutral[np.argmax(neutral[:, 2])]
    mouth = front + np.array([0.0, -0.05, -0.02])
    cheek = front + np.array([0.045, -0.02, -0.03])
    deltas = np.zeros((len(COEFFICIENT_NAMES), *neutral.shape))
    for k, name in enumerate(COEFFICIENT_NAMES):
        centre = cheek if name.startswith("cheek") else front if name.startswith("nose") else mouth
        if name.endswith("Right"):
            centre = centre * np.array([-1.0, 1.0, 1.0])
        sigma = 0.03 if name == "jawOpen" else 0.015
        weight = np.exp(-((neutral - centre) ** 2).sum(axis=1) / (2 * sigma**2))
        direction = np.array([0.0, -1.0, 0.2]) if name == "jawOpen" else rng.normal(size=3)
        direction /= np.linalg.norm(direction)
        deltas[k] = (0.012 if name == "jawOpen" else 0.004) * weight[:, None] * direction
    return Rig(neutral, deltas, tuple(COEFFICIENT_NAMES), faces)


def _syllables(rng, num_frames: int) -> np.ndarray:
    env = np.zeros(num_frames)
    t = 0
    while t < num_frames:
        length = int(rng.integers(8, 25))
        if rng.random() < 0.7:
            env[t:t + length] = np.sin(np.linspace(0, np.pi, min(length, num_frames - t))) * rng.uniform(0.4, 1.0)
        t += length
    return env


#: Vertices of the ``rig="random"`` speakers of :class:`FakeBlendVOCA`.
RANDOM_RIG_VERTICES = 60
#: The shape those rigs have besides the 32 coefficient names (a rig may hold more shapes than a dataset's names).
RANDOM_RIG_EXTRA_SHAPE = "browInnerUp"


def _subject_names(spec, prefix: str) -> list:
    """``spec`` subjects: a count (``<prefix>0``, ``<prefix>1``, ...) or the names themselves."""
    if isinstance(spec, (int, np.integer)) and not isinstance(spec, bool):
        return [f"{prefix}{i}" for i in range(int(spec))]
    if isinstance(spec, str) or not all(isinstance(name, str) for name in spec):
        raise TypeError(f"FakeBlendVOCA: a split is a number of subjects or a sequence of names, got {spec!r}")
    return list(spec)


def _random_rig(rng, names):
    """A well-conditioned rig on random vertices: ``names`` plus one extra shape, small random deltas."""
    from blendvoca.rig import Rig

    shapes = tuple(names) + (RANDOM_RIG_EXTRA_SHAPE,)
    # 32 random shapes on 60 vertices (180 equations): the coefficients are well determined.
    neutral = rng.normal(size=(RANDOM_RIG_VERTICES, 3))
    deltas = 0.01 * rng.normal(size=(len(shapes), RANDOM_RIG_VERTICES, 3))
    return Rig(neutral, deltas, shapes, np.array([[0, 1, 2], [1, 2, 3]]))


class FakeBlendVOCA:
    """A small in-memory dataset with the interface of ``benchmark.data.open_blendvoca``
    (a :class:`benchmark.methods.Dataset`).

    By default: subjects ``FakeTrain0..``, ``FakeVal0..``, ``FakeTest0..``; each has a
    rig on a small ellipsoid head and ``sentences`` sentences of 130-170 frames
    whose jawOpen follows the loudness of noise-burst "speech" (mouthClose its
    opposite), the other coefficients around 0.05; source vertices equal to the rig
    driven by the track, the template (the rig neutral) and faces.

    Parameters
    ----------
    seed : int
    train, val, test : int or sequence of str
        Subjects per split: a count (named ``FakeTrain0``, ...) or the names.
    sentences : int
        Sentences per subject (``sentence01``, ...).
    frames : (int, int)
        Frame counts are drawn from ``[low, high)`` (60 fps).
    tracks : {"speech", "smooth"}
        ``"speech"``: jawOpen follows the audio's loudness (a method can learn it
        from the audio). ``"smooth"``: every coefficient a slow sinusoid in
        [0.1, 0.9] moving less than 0.1 per frame (within the fit's rate bound,
        so a fit recovers it exactly), over noise audio.
    noise : float
        Standard deviation of the other coefficients around 0.05 (``"speech"``;
        0: constant 0.05).
    rig : {"head", "random"}
        ``"head"``: 32 localized smooth shapes on an ellipsoid head (642 vertices).
        ``"random"``: :data:`RANDOM_RIG_VERTICES` random vertices with the 32 shapes and
        :data:`RANDOM_RIG_EXTRA_SHAPE` as random offsets (every coefficient is
        recoverable from vertices).
    manifest_hash : str, optional
        Default ``"fake-blendvoca-seed<seed>"``.
    """

    def __init__(self, seed: int = 0, *, train=2, val=1, test=1, sentences: int = 2,
                 frames: tuple[int, int] = (130, 171), tracks: str = "speech", noise: float = 0.02,
                 rig: str = "head", manifest_hash: str | None = None):
        if tracks not in ("speech", "smooth"):
            raise ValueError(f"FakeBlendVOCA: tracks must be 'speech' or 'smooth', got {tracks!r}")
        if rig not in ("head", "random"):
            raise ValueError(f"FakeBlendVOCA: rig must be 'head' or 'random', got {rig!r}")
        rng = np.random.default_rng(seed)
        self.root = None
        self.names = tuple(COEFFICIENT_NAMES)
        self._splits = {"train": _subject_names(train, "FakeTrain"), "val": _subject_names(val, "FakeVal"),
                        "test": _subject_names(test, "FakeTest")}
        self.subjects = sorted({s for subjects in self._splits.values() for s in subjects})
        self.manifest_hash = f"fake-blendvoca-seed{seed}" if manifest_hash is None else str(manifest_hash)
        if rig == "head":
            base, self._faces = _head_mesh()
        else:
            self._faces = np.array([[0, 1, 2], [1, 2, 3]], dtype=np.int64)
        self._rigs, self._data = {}, {}
        jaw, close = self.names.index("jawOpen"), self.names.index("mouthClose")
        for subject in self.subjects:
            if rig == "head":
                neutral = base * rng.uniform(0.95, 1.05, size=3)
                self._rigs[subject] = _fake_rig(neutral, self._faces, rng)
            else:
                self._rigs[subject] = _random_rig(rng, self.names)
            for j in range(1, sentences + 1):
                num_frames = int(rng.integers(*frames))
                if tracks == "speech":
                    env = _syllables(rng, num_frames)
                    coeffs = np.clip(0.05 + noise * rng.standard_normal((num_frames, len(self.names))), 0, 1)
                    coeffs[:, jaw] = 0.8 * env
                    coeffs[:, close] = 0.3 * (1 - env)
                    n = round(num_frames / FPS * AUDIO_RATE)
                    amp = np.interp(np.arange(n) * FPS / AUDIO_RATE, np.arange(num_frames), env)
                    audio = (amp * rng.standard_normal(n) * 0.3).astype(np.float32)
                else:
                    t = np.arange(num_frames)[:, None]
                    freq = rng.uniform(0.005, 0.03, size=len(self.names))  # slope <= 0.4 * 2 pi * 0.03 < 0.1
                    coeffs = 0.5 + 0.4 * np.sin(2 * np.pi * freq * t + rng.uniform(0, 6, size=len(self.names)))
                    audio = (0.1 * rng.standard_normal(num_frames * AUDIO_RATE // FPS)).astype(np.float32)
                self._data[(subject, f"sentence{j:02d}")] = (audio, coeffs)

    @property
    def splits(self) -> dict:
        return {k: list(v) for k, v in self._splits.items()}

    def split(self, name: str) -> list:
        if name not in self._splits:
            raise ValueError(f"FakeBlendVOCA.split: unknown split {name!r}; expected one of {sorted(self._splits)}")
        return list(self._splits[name])

    def sentences(self, subject: str) -> list:
        return sorted(q for s, q in self._data if s == subject)

    def coeffs(self, subject: str, sentence: str) -> np.ndarray:
        return self._data[(subject, sentence)][1].copy()

    def samples(self, subject: str, sentence: str) -> np.ndarray:
        return self.coeffs(subject, sentence)[None]

    def audio(self, subject: str, sentence: str):
        return self._data[(subject, sentence)][0].copy(), AUDIO_RATE

    def rig(self, subject: str):
        return self._rigs[subject]

    def utterance(self, subject: str, sentence: str, split: str | None = None) -> Utterance:
        if split is None:
            split = next(name for name, subjects in self._splits.items() if subject in subjects)
        audio, _ = self.audio(subject, sentence)
        return Utterance(subject=subject, sentence=sentence, split=split, audio=audio,
                         num_frames=self.coeffs(subject, sentence).shape[0])

    def vertices(self, subject: str, sentence: str) -> np.ndarray:
        """``(T, V, 3)`` metres at 60 fps: the rig driven by the sentence's track."""
        rig = self._rigs[subject]
        if rig.names != self.names:
            rig = rig.select(self.names)
        coeffs = self.coeffs(subject, sentence)
        return rig.neutral[None] + np.tensordot(coeffs, rig.deltas, axes=(1, 0))

    def template(self, subject: str) -> np.ndarray:
        return self._rigs[subject].neutral.copy()

    def faces(self) -> np.ndarray:
        return self._faces.copy()

    def __repr__(self) -> str:
        return f"FakeBlendVOCA(subjects={len(self.subjects)})"


@dataclass
class CheckReport:
    """What :func:`check_method` verified."""

    name: str
    output: str
    stochastic: bool
    samples: int
    shapes: dict = field(default_factory=dict)


def _fail(step: str, cls, message: str, exc: BaseException | None = None):
    detail = ""
    if exc is not None:
        detail = f"\n  caused by {type(exc).__name__}: {exc}\n" + "".join(traceback.format_tb(exc.__traceback__)[-3:])
    raise MethodCheckError(f"check_method({cls.__name__}) failed at '{step}': {message}{detail}") from exc


def _generate_all(method, dataset, samples: int, seed: int):
    vertices = {}
    with progress_bars(False):
        tracks, _ = generated_tracks(method, dataset, split="test", samples=samples, seed=seed, vertices_out=vertices)
    return tracks, vertices


def _generated_or_fail(step: str, cls, method, dataset, samples: int, seed: int):
    """:func:`_generate_all`, with a method error reported as a failure of ``step``."""
    from benchmark.methods.validate import MethodError, MethodOutputError

    try:
        return _generate_all(method, dataset, samples, seed)
    except (MethodError, MethodOutputError) as exc:
        _fail(step, cls, str(exc), exc.__cause__)


def _same(a: dict, b: dict, *, atol: float) -> str | None:
    for key in a:
        if key not in b or a[key].shape != b[key].shape:
            return f"{key}: shape {a[key].shape} vs {b.get(key, np.empty(0)).shape}"
        if not np.allclose(a[key], b[key], rtol=1e-5, atol=atol):
            return f"{key}: largest difference {np.abs(a[key] - b[key]).max():.3g}"
    return None


@contextlib.contextmanager
def _other_global_random_state(seed: int):
    """Seed Python's, NumPy's and (when imported) torch's global generators with ``seed``
    for the block, and give them back their state after it."""
    import random
    import sys

    torch = sys.modules.get("torch")
    saved = (random.getstate(), np.random.get_state(), None if torch is None else torch.random.get_rng_state())
    random.seed(seed)
    np.random.seed(seed)
    if torch is not None:
        torch.manual_seed(seed)
    try:
        yield
    finally:
        random.setstate(saved[0])
        np.random.set_state(saved[1])
        if torch is not None:
            torch.random.set_rng_state(saved[2])


def check_method(cls, *, max_steps: int = 5, samples: int = 2, seed: int = 0, dataset=None, **config) -> CheckReport:
    """Check a method plug-in against the contract (docs/methods.md); raise :class:`MethodCheckError` if it breaks it.

    Parameters
    ----------
    cls : type
        The ``Method`` subclass (e.g. ``get_method("mean")``).
    max_steps : int
        Training budget (steps) on the fake dataset.
    samples : int
        Samples asked of stochastic methods.
    seed : int
    dataset : optional
        Dataset to train and generate on (default: a :class:`FakeBlendVOCA`).
    **config
        Constructor keyword arguments.

    Returns
    -------
    CheckReport
    """
    if not (isinstance(cls, type) and issubclass(cls, Method)):
        raise MethodCheckError(f"check_method: expected a subclass of benchmark.methods.Method, got {cls!r}")
    if not isinstance(getattr(cls, "name", None), str) or not cls.name:
        _fail("class attributes", cls, f"'name' must be a non-empty str, got {getattr(cls, 'name', None)!r}")
    if cls.output not in OUTPUT_KINDS:
        _fail("class attributes", cls, f"'output' must be one of {OUTPUT_KINDS}, got {cls.output!r}")
    try:
        method = cls(**config)
    except Exception as exc:
        _fail("construct", cls, f"{cls.__name__}(**{config!r}) raised", exc)
    try:
        cfg = method.config()
        text = json.dumps(cfg, sort_keys=True)
    except Exception as exc:
        _fail("config", cls, "config() must return a JSON-serialisable dict", exc)
    lost = {k: v for k, v in config.items() if json.dumps(cfg.get(k, "<missing>"), sort_keys=True)
            != json.dumps(v, sort_keys=True)}
    if lost:
        _fail("config round trip", cls, f"config() = {cfg!r} does not report the constructor arguments {lost!r}; "
                                        "pass every setting to Method.__init__(**config)")
    try:
        rebuilt = type(method)(**json.loads(text))
    except Exception as exc:
        _fail("config round trip", cls, f"type(m)(**m.config()) must rebuild the method; config() = {cfg!r}", exc)
    if json.dumps(rebuilt.config(), sort_keys=True) != text:
        _fail("config round trip", cls, f"type(m)(**m.config()).config() = {rebuilt.config()!r} differs from "
                                        f"m.config() = {cfg!r}")

    dataset = dataset if dataset is not None else FakeBlendVOCA(seed=seed)
    try:
        call_train(method, dataset, TrainingRequest(seed=seed, budget=Budget(max_steps=max_steps)))
    except Exception as exc:
        _fail("train", cls, f"train(FakeBlendVOCA, TrainingRequest(seed={seed}, budget=Budget(max_steps={max_steps}))) raised", exc)
    num_samples = samples if cls.stochastic else 1
    tracks, vertices = _generated_or_fail("generate", cls, method, dataset, num_samples, seed)
    again, again_vertices = _generate_all(method, dataset, num_samples, seed)
    problem = _same(tracks, again, atol=1e-6) or _same(vertices, again_vertices, atol=1e-7)
    if problem:
        _fail("same seed, same output", cls, f"two generate calls with the same seed differ ({problem}); "
                                            "draw every random number from the seed argument")
    # a second process: another global random state, the same seed and step budget
    with _other_global_random_state(seed + 7919):
        try:
            twin = cls(**config)
            call_train(twin, dataset, TrainingRequest(seed=seed, budget=Budget(max_steps=max_steps)))
        except Exception as exc:
            _fail("same seed, same training", cls, "constructing and training a second instance raised", exc)
    twin_tracks, twin_vertices = _generated_or_fail("same seed, same training", cls, twin, dataset, num_samples, seed)
    problem = _same(tracks, twin_tracks, atol=1e-6) or _same(vertices, twin_vertices, atol=1e-7)
    if problem:
        _fail("same seed, same training", cls,
              f"two trainings with seed={seed} and the same step budget generate differently ({problem}); draw the "
              "initial weights, batches and noise from the seed argument (e.g. torch.manual_seed(seed) before "
              "building the network), not from the global random state")
    with tempfile.TemporaryDirectory(prefix="check_method-") as tmp:
        try:
            method.save(Path(tmp))
        except Exception as exc:
            _fail("save", cls, f"save({tmp}) raised", exc)
        try:
            loaded = cls.load(Path(tmp))
        except Exception as exc:
            _fail("load", cls, f"{cls.__name__}.load({tmp}) raised", exc)
    if json.dumps(loaded.config(), sort_keys=True) != text:
        _fail("load", cls, f"the loaded method's config {loaded.config()!r} differs from the saved {cfg!r}")
    after, after_vertices = _generated_or_fail("generate after load", cls, loaded, dataset, num_samples, seed)
    problem = _same(tracks, after, atol=1e-5) or _same(vertices, after_vertices, atol=1e-6)
    if problem:
        _fail("save/load", cls, f"the loaded method generates differently from the trained one ({problem}); "
                                "save() must store all learned state")
    shapes = {f"{s}/{q}": list((vertices if cls.output == "vertices" else tracks)[(s, q)].shape) for s, q in tracks}
    return CheckReport(name=cls.name, output=cls.output, stochastic=bool(cls.stochastic), samples=num_samples,
                       shapes=shapes)
