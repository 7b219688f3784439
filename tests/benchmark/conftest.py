import pytest

from tests.benchmark.fakes import make_dataset


@pytest.fixture(scope="session")
def fake_dataset_dir(tmp_path_factory, assets_dir):
    """A tiny fabricated BlendVOCA build (3 subjects x 3 sentences, 150-200 frames)."""
    return make_dataset(tmp_path_factory.mktemp("blendvoca"), assets_dir)
