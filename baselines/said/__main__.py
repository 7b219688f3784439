"""``python -m baselines.said`` is ``python -m baselines.said.generate``."""

import sys

from baselines.said.generate import main

sys.exit(main())
