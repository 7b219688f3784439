"""``python -m baselines.said`` is ``python -m baselines.said.generate``."""

from baselines.said.generate import main

main()
