"""``python -m benchmark.generate --image``: the coefficients as a labelled image (a row per
blendshape name, time in seconds, the method and audio in the title, a colour bar), the
image's pixels being the track; refused for vertex methods and other suffixes."""

import matplotlib.image
import numpy as np
import pytest

import blendvoca.builder.report as report
from benchmark import generate as gen
from benchmark.methods import COEFFICIENT_NAMES, Method, register, unregister
from blendvoca import cli
from blendvoca.io.audio import write_wav
from blendvoca.io.coeffs import read_coeffs_csv


@pytest.fixture
def wav(tmp_path):
    path = tmp_path / "hello.wav"
    t = np.arange(int(1.5 * 16000)) / 16000
    write_wav(path, (0.2 * np.sin(2 * np.pi * 3 * t) * np.sin(2 * np.pi * 220 * t)).astype(np.float32), 16000)
    return path


class Ramp(Method):
    """Trains nothing; coefficient k of frame t is ``(t / T) * (k + 1) / 32`` (each row its own ramp)."""

    def generate(self, utterance, *, samples=1, seed=0):
        T = utterance.num_frames
        track = (np.arange(T)[:, None] / T) * (np.arange(1, 33)[None] / 32)
        return track[None]


class Heads(Method):
    output = "vertices"

    def generate(self, utterance, *, samples=1, seed=0):
        return np.zeros((1, utterance.num_frames, 4, 3), np.float32)


@pytest.fixture(autouse=True)
def registered():
    register("test-ramp")(Ramp)
    register("test-heads")(Heads)
    yield
    unregister("test-ramp")
    unregister("test-heads")


def test_the_image_is_labelled_and_its_pixels_are_the_track(wav, tmp_path, monkeypatch):
    kept = {}
    save = report._save_figure

    def keep(fig, path):
        fig.canvas.draw()
        kept["fig"] = fig
        save(fig, path)

    monkeypatch.setattr(report, "_save_figure", keep)
    out, image = tmp_path / "r.csv", tmp_path / "r.png"
    assert gen.main(["--method", "test-ramp", "--audio", str(wav), "--out", str(out), "--image", str(image)]) == 0
    coeffs, names = read_coeffs_csv(out)
    ax = kept["fig"].axes[0]
    assert [t.get_text() for t in ax.get_yticklabels()] == list(COEFFICIENT_NAMES)  # a row per name
    assert "test-ramp" in ax.get_title() and "hello.wav" in ax.get_title()
    assert ax.get_xlabel().startswith("time (s)")
    picture = ax.get_images()[0]
    np.testing.assert_allclose(picture.get_array(), coeffs.T, atol=1e-6)  # row k = blendshape k, column t = frame t
    left, right, bottom, top = picture.get_extent()
    assert (left, right) == (0.0, pytest.approx(coeffs.shape[0] / 60.0))  # the time axis in seconds
    assert kept["fig"].axes[1].get_ylabel() == "coefficient"  # the colour bar
    png = matplotlib.image.imread(image)
    assert png.shape[1] > png.shape[0] > 300  # wider than tall, tall enough for 32 labelled rows
    # not a black strip: light where the coefficients are 0, dark where they are 1
    assert png[..., :3].mean() > 0.5


def test_several_samples_get_numbered_images(wav, tmp_path):
    argv = ["--method", "random", "--audio", str(wav), "--out", str(tmp_path / "r.csv"), "--samples", "2",
            "--image", str(tmp_path / "r.png")]
    assert gen.main(argv) == 0
    assert (tmp_path / "r-0.png").is_file() and (tmp_path / "r-1.png").is_file()


@pytest.mark.parametrize("method, image, words", [
    ("test-heads", "h.png", ["outputs vertices", "--image"]),
    ("test-ramp", "h.jpg", ["--image", ".png", "'.jpg'"]),
])
def test_refused_images_are_one_error_line_and_nothing_written(method, image, words, wav, tmp_path, capsys):
    out = tmp_path / ("h.npy" if method == "test-heads" else "h.csv")
    assert gen.main(["--method", method, "--audio", str(wav), "--out", str(out),
                     "--image", str(tmp_path / image)]) == cli.EXIT_USER
    err = [line for line in capsys.readouterr().err.splitlines() if line.strip()]
    assert len(err) == 1 and err[0].startswith("error: ") and all(w in err[0] for w in words), err
    assert not out.exists() and not (tmp_path / image).exists()
