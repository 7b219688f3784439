import numpy as np
import pytest
import trimesh

from blendvoca.io.mesh import (
    MeshFormatError,
    read_mesh,
    read_ply_sequence,
    read_ply_vertices,
    write_obj,
    write_ply,
)


@pytest.fixture()
def mesh():
    rng = np.random.default_rng(0)
    V = rng.normal(size=(50, 3)).astype(np.float32).astype(np.float64)  # float32-exact
    F = rng.integers(0, 50, size=(80, 3))
    return V, F


@pytest.mark.parametrize("suffix,binary", [(".ply", True), (".ply", False), (".obj", None)])
def test_round_trip_keeps_vertex_order_and_values(tmp_path, mesh, suffix, binary):
    V, F = mesh
    path = tmp_path / f"m{suffix}"
    if suffix == ".obj":
        write_obj(path, V, F)
    else:
        write_ply(path, V, F, binary=binary)
    V2, F2 = read_mesh(path)
    assert V2.dtype == np.float64 and F2.dtype == np.int64
    np.testing.assert_array_equal(F2, F)
    if binary:
        np.testing.assert_array_equal(V2, V)
    else:
        np.testing.assert_allclose(V2, V, rtol=0, atol=1e-8)


def test_obj_text_is_one_record_per_line_with_nine_significant_digits(tmp_path):
    # An independent line-by-line rendering of the OBJ records gives the same bytes.
    rng = np.random.default_rng(3)
    V = rng.normal(size=(40, 3)) * 10.0 ** rng.integers(-6, 3, size=(40, 1))
    F = rng.integers(0, 40, size=(70, 3))
    write_obj(tmp_path / "m.obj", V, F)
    expected = "".join("v {} {} {}\n".format(*(format(float(x), ".9g") for x in v)) for v in V)
    expected += "".join(f"f {a + 1} {b + 1} {c + 1}\n" for a, b, c in F)
    assert (tmp_path / "m.obj").read_bytes() == expected.encode()
    write_obj(tmp_path / "empty.obj", np.zeros((0, 3)), np.zeros((0, 3), dtype=int))
    assert (tmp_path / "empty.obj").read_bytes() == b"\n"


def test_matches_trimesh_on_the_flame_template(assets_dir):
    path = assets_dir / "voca" / "FLAME_sample.ply"
    V, F = read_mesh(path)
    reference = trimesh.load(path, process=False)
    assert V.shape == (5023, 3) and F.shape == (9976, 3)
    np.testing.assert_array_equal(V, reference.vertices)
    np.testing.assert_array_equal(F, reference.faces)


def test_obj_with_texture_indices_keeps_vertex_order(tmp_path):
    (tmp_path / "t.obj").write_text(
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nvt 1 1\nvt 0.5 0.5\n"
        "f 1/1 2/2 3/3\nf 2/5 4/4 3/3\n"
    )
    V, F = read_mesh(tmp_path / "t.obj")
    assert V.shape == (4, 3)
    np.testing.assert_array_equal(F, [[0, 1, 2], [1, 3, 2]])


def test_quads_are_fan_triangulated(tmp_path):
    (tmp_path / "q.obj").write_text("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n")
    _, F = read_mesh(tmp_path / "q.obj")
    np.testing.assert_array_equal(F, [[0, 1, 2], [0, 2, 3]])


def test_vertex_only_ply_and_sequence(tmp_path, mesh):
    V, F = mesh
    paths = []
    for t in range(4):
        paths.append(tmp_path / f"f{t}.ply")
        write_ply(paths[-1], V + t, None if t % 2 else F)
    frames = read_ply_sequence(paths)
    assert frames.shape == (4, 50, 3)
    np.testing.assert_array_equal(frames[3], (V + 3).astype(np.float32))  # PLY stores float32
    np.testing.assert_array_equal(read_ply_vertices(paths[0]), V)


def test_truncated_ply_names_file_and_frame(tmp_path, mesh):
    V, F = mesh
    good, bad = tmp_path / "a.ply", tmp_path / "b.ply"
    write_ply(good, V, F)
    bad.write_bytes(good.read_bytes()[:300])
    with pytest.raises(MeshFormatError, match=r"frame 2 of 2.*b\.ply.*truncated"):
        read_ply_sequence([good, bad])


def test_wrong_vertex_count_in_sequence(tmp_path, mesh):
    V, F = mesh
    write_ply(tmp_path / "a.ply", V)
    write_ply(tmp_path / "b.ply", V[:-1])
    with pytest.raises(MeshFormatError, match="49 vertices, expected 50"):
        read_ply_sequence([tmp_path / "a.ply", tmp_path / "b.ply"])


def test_unsupported_suffix_and_garbage(tmp_path):
    with pytest.raises(ValueError, match="unsupported mesh format"):
        read_mesh(tmp_path / "x.stl")
    (tmp_path / "g.ply").write_bytes(b"not a mesh")
    with pytest.raises(MeshFormatError, match="not a PLY"):
        read_mesh(tmp_path / "g.ply")
