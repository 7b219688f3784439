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
