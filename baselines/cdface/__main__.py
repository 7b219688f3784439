"""``python -m baselines.cdface`` is ``python -m baselines.cdface.generate``."""

import sys

from baselines.cdface.generate import main

sys.exit(main())
