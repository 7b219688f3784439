"""BlendVOCA benchmark: dataset reader, metrics, feature extractor, lip sync,
rendering, evaluation protocol, method registry and runner.

Submodules are imported on demand (``benchmark.metrics``, ``benchmark.evaluation`` ...)
so that importing the package stays light.
"""
