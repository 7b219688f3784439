"""``python -m blendvoca.format compare A B``: see :mod:`blendvoca.format.compare`."""

import sys

from .compare import main

if __name__ == "__main__":
    sys.exit(main())
