"""The study server behind ``python -m benchmark.study serve``: the application
(:mod:`.app`), the answers' database (:mod:`.store`), the order of the screens (:mod:`.steps`)
and the pages (:mod:`.pages`)."""

from benchmark.study.server.app import create_app
from benchmark.study.server.store import Store, open_store

__all__ = ["create_app", "Store", "open_store"]
