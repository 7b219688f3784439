"""The one reader and writer of torch files: safe loads only, messages that say what a file is not."""

import pickle
import zipfile

import numpy as np
import pytest
import torch

from blendvoca.errors import DataError, UserError
from blendvoca.io.torch_file import REFUSED_OBJECTS, read_torch_file, safe_payload, write_torch_file


class _Payload:
    """Unpickling it creates the file ``marker`` (what a malicious checkpoint would do)."""

    def __init__(self, marker):
        self.marker = str(marker)

    def __reduce__(self):
        return open, (self.marker, "w")


def bad_checkpoints(folder, marker) -> dict:
    """``{kind: path}`` of files that are no checkpoint, and of files whose pickle would
    create ``marker`` when loaded unsafely."""
    folder.mkdir(parents=True, exist_ok=True)
    good = folder / "good.pt"
    torch.save({"w": torch.arange(100.0)}, good)
    files = {"empty": b"", "truncated": good.read_bytes()[: good.stat().st_size // 2],
             "random": np.random.default_rng(0).integers(0, 256, 4096, dtype=np.uint8).tobytes(),
             "text": b"not a checkpoint\n",
             "raw-pickle": pickle.dumps({"w": _Payload(marker)}, protocol=4),
             "raw-pickle-2": pickle.dumps({"w": _Payload(marker)}, protocol=2)}
    paths = {}
    for kind, data in files.items():
        paths[kind] = folder / f"{kind}.pt"
        paths[kind].write_bytes(data)
    paths["torch-pickle"] = folder / "torch-pickle.pt"
    torch.save({"state_dict": {"w": torch.zeros(2)}, "x": _Payload(marker)}, paths["torch-pickle"])
    good.unlink()
    return paths


@pytest.mark.parametrize("kind, says", [
    ("empty", "the file is empty"),
    ("truncated", "damaged zip archive"),
    ("random", "neither a torch zip archive nor a legacy torch file"),
    ("text", "neither a torch zip archive nor a legacy torch file"),
    ("raw-pickle", "neither a torch zip archive nor a legacy torch file"),
    ("raw-pickle-2", REFUSED_OBJECTS),
    ("torch-pickle", REFUSED_OBJECTS),
])
def test_a_file_that_is_no_checkpoint_says_what_it_is_not_and_runs_nothing(tmp_path, recwarn, kind, says):
    marker = tmp_path / "MARKER"
    path = bad_checkpoints(tmp_path / "files", marker)[kind]
    with pytest.raises(DataError) as caught:
        read_torch_file(path, where="reader")
    message = str(caught.value)
    assert message.startswith(f"reader: {path} is not a readable torch checkpoint: ") and says in message, message
    assert "\n" not in message and len(message) < 400, message
    assert not any(word in message for word in ("file an issue", "Weights only load failed", "miniz")), message
    assert not marker.exists()
    assert not [w for w in recwarn if "file an issue" in str(w.message)]  # torch's pickle-protocol warning


def test_a_call_that_would_run_is_named_and_numpy_objects_get_the_hint(tmp_path):
    marker = tmp_path / "MARKER"
    path = bad_checkpoints(tmp_path, marker)["torch-pickle"]
    with pytest.raises(DataError, match=r"(io|builtins)\.open.*do not use a file of unknown origin") as caught:
        read_torch_file(path, where="reader", old_format_hint="convert it")
    assert "convert it" not in str(caught.value)  # a call is no old checkpoint: no converter advice
    old = tmp_path / "old.pt"
    torch.save({"templates": {"A": np.zeros((3, 3))}}, old)  # numpy pickled in, as earlier versions did
    with pytest.raises(DataError, match=r"numpy.*nothing of it was run; convert it$"):
        read_torch_file(old, where="reader", old_format_hint="convert it")
    assert not marker.exists()


def test_unsafe_load_is_only_on_request(tmp_path):
    old = tmp_path / "old.pt"
    torch.save({"a": np.arange(3)}, old)
    np.testing.assert_array_equal(read_torch_file(old, where="r", weights_only=False)["a"], np.arange(3))


def test_missing_file_is_a_user_error(tmp_path):
    with pytest.raises(UserError, match="expected a file at"):
        read_torch_file(tmp_path / "none.pt", where="r")


def test_safe_payload_round_trips_arrays_bit_for_bit(tmp_path):
    rng = np.random.default_rng(1)
    arrays = {"f64": rng.normal(size=(4, 3)), "f32": rng.normal(size=5).astype(np.float32),
              "i64": np.array([3, 1, 2]), "strided": rng.normal(size=(6, 4))[::2, 1:]}
    value = {"arrays": arrays, "scalar": np.float32(0.25), "n": np.int64(7), "tuple": (1, np.float64(2.0)),
             "path": tmp_path, "text": "x", "none": None, "list": [np.bool_(True)]}
    write_torch_file(tmp_path / "x.pt", safe_payload(value))
    back = read_torch_file(tmp_path / "x.pt", where="r")
    for key, array in arrays.items():
        got = back["arrays"][key].numpy()
        assert got.dtype == array.dtype
        np.testing.assert_array_equal(got, array)
    assert back["scalar"] == 0.25 and back["n"] == 7 and back["tuple"] == (1, 2.0) and back["list"] == [True]
    assert back["path"] == str(tmp_path) and back["text"] == "x" and back["none"] is None


def test_safe_payload_keeps_a_state_dict_as_it_is():
    state = torch.nn.BatchNorm1d(2).state_dict()
    assert safe_payload({"state_dict": state})["state_dict"] is state  # its _metadata (module versions) too


def test_write_refuses_what_a_safe_load_would_refuse(tmp_path):
    with pytest.raises(TypeError, match=r"payload\['t'\]\['A'\] is a numpy.ndarray"):
        write_torch_file(tmp_path / "x.pt", {"t": {"A": np.zeros(3)}})
    with pytest.raises(TypeError, match="object array"):
        safe_payload({"o": np.array([object()])})
    assert not (tmp_path / "x.pt").exists()


def test_a_damaged_member_of_a_valid_zip_is_named(tmp_path):
    good = tmp_path / "good.pt"
    torch.save({"w": torch.zeros(3)}, good)
    bad = tmp_path / "bad.pt"
    with zipfile.ZipFile(good) as src, zipfile.ZipFile(bad, "w") as dst:
        for info in src.infolist():
            data = src.read(info)
            dst.writestr(info, b"junk" if info.filename.endswith("data.pkl") else data)
    with pytest.raises(DataError, match="not a readable torch checkpoint") as caught:
        read_torch_file(bad, where="r")
    assert "file an issue" not in str(caught.value)
