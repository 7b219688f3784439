import numpy as np

from blendvoca.names import ARKIT_NAMES, BLENDVOCA_NAMES, MIRROR_PAIRS, mirror_permutation


def test_blendvoca_names_match_the_asset(assets_dir):
    listed = (assets_dir / "said" / "ARKit_blendshapes.txt").read_text().split()
    assert tuple(listed) == BLENDVOCA_NAMES
    header = (assets_dir / "said" / "coeffs_std.csv").read_text().splitlines()[0].split(",")
    assert tuple(header) == BLENDVOCA_NAMES


def test_arkit_names_are_the_reference_rig_files(assets_dir):
    import zipfile

    with zipfile.ZipFile(assets_dir / "said" / "ARKit_reference_blendshapes.zip") as z:
        stems = sorted(n.split("/")[-1][:-4] for n in z.namelist() if n.endswith(".obj"))
    assert [s for s in stems if s != "Neutral"] == sorted(ARKIT_NAMES)
    assert set(BLENDVOCA_NAMES) <= set(ARKIT_NAMES)


def test_eleven_mirror_pairs_and_permutation_is_an_involution():
    assert len(MIRROR_PAIRS) == 11
    perm = mirror_permutation(BLENDVOCA_NAMES)
    assert np.array_equal(perm[perm], np.arange(32))
    for left, right in MIRROR_PAIRS:
        assert BLENDVOCA_NAMES[perm[BLENDVOCA_NAMES.index(left)]] == right
    assert perm[BLENDVOCA_NAMES.index("jawOpen")] == BLENDVOCA_NAMES.index("jawOpen")


# ----------------------------------------------------------------------------- conventions and remap

import subprocess  # noqa: E402
import sys  # noqa: E402
import warnings  # noqa: E402

import pytest  # noqa: E402

from blendvoca.errors import UserError  # noqa: E402
from blendvoca.names import (  # noqa: E402
    ARKIT_FACE_ORDER,
    CONVENTIONS,
    LIVELINK_SHAPE_COLUMNS,
    MissingShapesWarning,
    arkit_name,
    convention_names,
    pascal_name,
    remap,
    remap_columns,
)

FIXED = [name for name, c in CONVENTIONS.items() if c.names is not None]


def test_the_required_conventions_are_registered_with_a_source():
    for name in ("arkit52", "livelink", "unitalker51", "beat", "a2f52", "a2f46", "metahuman", "said32"):
        entry = CONVENTIONS[name]
        assert entry.source and entry.checked
        if entry.names is not None:
            assert len(entry.names) == entry.count == len(set(entry.names))
            assert all(arkit_name(n) == n for n in entry.names)


@pytest.mark.parametrize("name", FIXED)
def test_every_convention_to_arkit52_and_back_is_exact_on_the_shared_shapes(name):
    names = convention_names(name)
    rng = np.random.default_rng(len(name))
    track = rng.random((7, len(names)))
    lacks = CONVENTIONS[name].lacks
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        in_arkit = remap(track, name, "arkit52")
    # zero-filled shapes are named in one warning; a convention with all 52 warns of nothing
    assert [str(w.message).endswith(", ".join(lacks)) for w in caught] == ([True] if lacks else [])
    for k, shape in enumerate(names):
        assert np.array_equal(in_arkit[:, ARKIT_FACE_ORDER.index(shape)], track[:, k])
    back = remap(in_arkit, "arkit52", name, missing="refuse")
    assert np.array_equal(back, track)
    assert not in_arkit[:, [ARKIT_FACE_ORDER.index(s) for s in lacks]].any()


def test_zero_fill_warns_naming_the_shapes_and_refuse_raises_naming_them():
    track = np.ones((3, 32))
    with pytest.warns(MissingShapesWarning, match="eyeBlinkLeft.*tongueOut"):
        out = remap(track, "said32", "arkit52")
    assert out.shape == (3, 52) and out.sum() == 3 * 32
    with pytest.raises(UserError, match="no column for 1 shape.*mouthClose"):
        remap(np.ones((2, 51)), "metahuman", "said32", missing="refuse")
    with pytest.raises(UserError, match="missing must be one of"):
        remap(track, "said32", "arkit52", missing="ignore")


def test_remap_accepts_name_lists_in_any_case_and_checks_the_width():
    index, missing, dropped = remap_columns(["JawOpen", "tongueOut"], "said32")
    assert index[BLENDVOCA_NAMES.index("jawOpen")] == 0 and len(missing) == 31 and dropped == ("tongueOut",)
    with pytest.raises(UserError, match=r"expected a \(T, 52\) track"):
        remap(np.ones((2, 51)), "arkit52", "said32")
    with pytest.raises(UserError, match="unknown source blendshape names"):
        remap(np.ones((2, 1)), ["notAShape"], "arkit52")
    with pytest.raises(UserError, match="unknown blendshape convention 'nope'"):
        remap(np.ones((2, 1)), "nope", "arkit52")


def test_conventions_without_a_fixed_order_ask_for_the_files_names():
    for name in ("beat", "a2f46"):
        with pytest.raises(UserError, match="no fixed order"):
            remap(np.ones((2, 52)), name, "arkit52")


def test_livelink_columns_are_the_pascal_spelling_of_the_registry_order():
    assert LIVELINK_SHAPE_COLUMNS == tuple(pascal_name(n) for n in CONVENTIONS["livelink"].names)
    assert LIVELINK_SHAPE_COLUMNS.index("JawRight") < LIVELINK_SHAPE_COLUMNS.index("JawLeft")
    assert remap_columns("livelink", "arkit52")[1] == ()


def test_names_command_lists_and_shows_conventions():
    run = lambda *a: subprocess.run([sys.executable, "-m", "blendvoca.names", *a],  # noqa: E731
                                    capture_output=True, text=True)
    listed = run("list")
    assert listed.returncode == 0
    assert all(name in listed.stdout for name in CONVENTIONS)
    shown = run("show", "unitalker51")
    assert shown.returncode == 0 and "X-niper/UniTalker" in shown.stdout and "inhouse_arkit.npz" in shown.stdout
    assert "  19 jawOpen" in shown.stdout
    bad = run("show", "nope")
    assert bad.returncode == 2 and bad.stderr.startswith("error:") and "arkit52" in bad.stderr


def test_export_writes_a_conventions_columns_and_reads_back_by_name(tmp_path):
    from blendvoca.export import export_track, read_track

    track = np.random.default_rng(3).random((5, 32))
    aligned = export_track(tmp_path / "t.csv", track, BLENDVOCA_NAMES, "csv", convention="metahuman")
    header = (tmp_path / "t.csv").read_text().splitlines()[0].split(",")
    assert header == list(CONVENTIONS["metahuman"].columns()) and "MouthClose" not in header
    assert "mouthClose" in aligned.dropped and "eyeBlinkLeft" in aligned.missing
    coeffs, names, _ = read_track(tmp_path / "t.csv")
    shared = [n for n in BLENDVOCA_NAMES if n != "mouthClose"]
    got = remap(coeffs, names, shared, missing="refuse")
    np.testing.assert_allclose(got, remap(track, BLENDVOCA_NAMES, shared), atol=5e-7)
    with pytest.raises(UserError, match="csv format only"):
        export_track(tmp_path / "t.json", track, BLENDVOCA_NAMES, "arkit-json", convention="metahuman")


def test_canonical_names_any_case_and_refusals():
    from blendvoca.names import canonical_names

    assert canonical_names(["JawOpen", "mouthclose"], where="here") == ("jawOpen", "mouthClose")
    unknown = r"^here: unknown blendshape names \['nose'\]; expected ARKit names \(any case\)$"
    with pytest.raises(UserError, match=unknown):
        canonical_names(["jawOpen", "nose"], where="here")
    with pytest.raises(UserError, match=r"^here: blendshape names repeated: \['jawOpen'\]$"):
        canonical_names(["jawOpen", "JawOpen"], where="here")
