"""Repository-level pytest configuration: shared fixtures live in tests/fixtures/."""

pytest_plugins = ["tests.fixtures.assets", "tests.fixtures.corpus", "tests.fixtures.dataset"]
