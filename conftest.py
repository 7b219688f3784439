"""Repository-level pytest configuration: shared fixtures live in tests/fixtures/."""

pytest_plugins = ["tests.fixtures.assets", "tests.fixtures.corpus", "tests.fixtures.dataset"]

import pytest  # noqa: E402


@pytest.fixture(scope="session", autouse=True)
def _wind_fits_in_a_session_folder(tmp_path_factory):
    """The tests' ground-truth WInD fits go to a session folder, not the user's cache."""
    from benchmark.evaluation import latent

    folder = tmp_path_factory.mktemp("wind-gmm")
    default = latent.wind_cache_dir
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(latent, "wind_cache_dir", lambda cache: folder if cache is True else default(cache))
        yield
