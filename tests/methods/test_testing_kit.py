"""benchmark.testing.check_method: passes contract-abiding plug-ins of both output kinds and
names the step a broken one fails at; vertex outputs are fitted back to their coefficients."""

import numpy as np
import pytest

from benchmark.methods import Method, MethodOutputError, TrainingRequest, get_method
from benchmark.protocol import generated_tracks
from benchmark.testing import FakeBlendVOCA, MethodCheckError, check_method


def test_builtin_mean_passes():
    report = check_method(get_method("mean"))
    assert report.output == "coefficients" and report.samples == 1
    assert all(shape[0] == 1 and shape[2] == 32 for shape in report.shapes.values())


class RigDriven(Method):
    """Vertex-output method: each speaker's rig driven by a smooth, known track (stored at train)."""

    name = "rig-driven"
    output = "vertices"
    stochastic = True

    def __init__(self, level=0.3):
        super().__init__(level=level)

    contract = 3

    def train(self, dataset, request):
        self.rigs = {s: dataset.rig(s) for s in dataset.subjects}

    @staticmethod
    def known_track(num_frames, level, phase=0.0):
        t = np.arange(num_frames) / 60.0
        track = np.full((num_frames, 32), 0.1)
        track[:, 0] = level * (1 + np.sin(2 * np.pi * 2 * t + phase)) / 2  # rate <= 0.1 per frame
        return track

    def generate(self, utterance, *, samples=1, seed=0):
        rig = self.rigs[utterance.subject]
        rng = np.random.default_rng(seed)
        tracks = [self.known_track(utterance.num_frames, self._config["level"], rng.uniform(0, 6)) for _ in range(samples)]
        return np.stack([rig.neutral[None] + np.tensordot(c, rig.deltas, axes=(1, 0)) for c in tracks])

    def save(self, directory):
        super().save(directory)
        import pickle

        (directory / "rigs.pkl").write_bytes(pickle.dumps(self.rigs))

    @classmethod
    def load(cls, directory):
        import pickle

        method = super().load(directory)
        method.rigs = pickle.loads((directory / "rigs.pkl").read_bytes())
        return method


def test_vertex_method_passes_and_its_vertices_are_fitted_to_the_known_track():
    report = check_method(RigDriven, level=0.4)
    assert report.output == "vertices" and report.samples == 2
    dataset = FakeBlendVOCA(seed=3)
    method = RigDriven(level=0.4)
    method.train(dataset, TrainingRequest(seed=0))
    vertices = {}
    tracks, _ = generated_tracks(method, dataset, samples=2, seed=5, vertices_out=vertices)
    for (subject, sentence), fitted in tracks.items():
        assert fitted.shape == (2, dataset.coeffs(subject, sentence).shape[0], 32)
        assert vertices[(subject, sentence)].shape[2:] == dataset.template(subject).shape
        # the rig reproduces the vertices exactly: the QP recovers the track that drove it
        mesh = vertices[(subject, sentence)][0]
        rig = dataset.rig(subject)
        assert np.abs(rig.neutral[None] + np.tensordot(fitted[0], rig.deltas, axes=(1, 0)) - mesh).max() < 1e-6


class _Broken(Method):
    name = "broken"

    def __init__(self, mode="ok"):
        super().__init__(mode=mode)
        self.mode = mode
        self.state = None

    contract = 3

    def train(self, dataset, request):
        self.state = 0.5

    def generate(self, utterance, *, samples=1, seed=0):
        out = np.full((samples, utterance.num_frames, 32), self.state if self.state is not None else 0.2)
        if self.mode == "unseeded":
            out += np.random.default_rng().uniform(0, 0.1, size=out.shape)
        if self.mode == "frames":
            out = out[:, :-2]
        return out


@pytest.mark.parametrize("mode, step", [
    ("unseeded", "same seed, same output"),
    ("frames", "generate"),
    ("ok", "save/load"),  # save() does not store the trained state
])
def test_broken_plugins_fail_at_the_named_step(mode, step):
    with pytest.raises(MethodCheckError, match=f"failed at '{step}'"):
        check_method(_Broken, mode=mode)


def test_config_round_trip_is_checked():
    class Forgets(Method):
        name = "forgets"

        def __init__(self, width=3):
            super().__init__()  # config() misses width

        def generate(self, utterance, *, samples=1, seed=0):
            return np.zeros((samples, utterance.num_frames, 32))

    with pytest.raises(MethodCheckError, match="config round trip"):
        check_method(Forgets, width=5)
    with pytest.raises(MethodCheckError, match="subclass of benchmark.methods.Method"):
        check_method(object)


def test_vertex_output_in_the_wrong_unit_is_refused():
    class Millimetres(RigDriven):
        def generate(self, utterance, *, samples=1, seed=0):
            return super().generate(utterance, samples=samples, seed=seed) * 1000.0

    with pytest.raises(MethodCheckError, match="metres"):
        check_method(Millimetres)
    assert issubclass(MethodCheckError, AssertionError) and MethodOutputError
