"""``python -m blendvoca.retarget``: the command line of :mod:`blendvoca.retarget.cli`."""

import sys

from blendvoca.retarget.cli import main

if __name__ == "__main__":
    sys.exit(main())
