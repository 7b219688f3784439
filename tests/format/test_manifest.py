"""What a build's manifest records: the same fields for a VOCASET build and a coefficient-corpus build."""

import types

import blendvoca
from blendvoca.format import file_digest, read_manifest, write_manifest
from blendvoca.format.manifest import BUILD_TOOL, blas_kernels, write_dataset_manifest

FILES = ["blendshape_coeffs/s1/sentence01.csv", "rigs/s1.npz", "audio/s1/sentence01.wav"]


def _folder(tmp_path):
    for rel in FILES:
        (tmp_path / rel).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / rel).write_bytes(rel.encode())
    return tmp_path


def test_dataset_manifest_records(tmp_path):
    root = _folder(tmp_path)
    write_dataset_manifest(root, files=FILES + FILES[:1], dataset={"name": "beat"}, params={"p": 1},
                           failures=[], recipe={"id": "0" * 64})
    manifest = read_manifest(root)
    assert manifest == {
        "tool": BUILD_TOOL, "version": blendvoca.__version__, "parameters": {"p": 1}, "dataset": {"name": "beat"},
        "failures": [], "recipe": {"id": "0" * 64},
        "files": {rel: file_digest(root / rel) for rel in sorted(FILES)},
        "tolerances": {"blendshape_coeffs/s1/sentence01.csv": 2e-2, "rigs/s1.npz": 2e-3},
    }


def test_build_manifest_records(tmp_path, assets_dir):
    root = _folder(tmp_path)
    corpus = types.SimpleNamespace(subjects=["s1"], layout="registereddata")
    write_manifest(root, files=FILES, vocaset=tmp_path, corpus=corpus, params={}, failures=[],
                   records={("s1", "sentence01"): {"inputs": {"a": 1}}}, rig_records={"s1": None}, version="9",
                   tolerances={"rigs/s1.npz": 0.5})
    manifest = read_manifest(root)
    assert sorted(manifest) == ["blas", "failures", "files", "inputs", "parameters", "tolerances", "tool", "version"]
    assert manifest["blas"] == blas_kernels() and manifest["version"] == "9"
    assert manifest["tolerances"] == {"rigs/s1.npz": 0.5}
    assert manifest["inputs"]["speakers"] == {"s1": {"template": {}, "sentences": {"sentence01": {"a": 1}}}}
    assert manifest["files"] == {rel: file_digest(root / rel) for rel in sorted(FILES)}
