"""``python -m wheelrom``: the ``wheelrom`` command (the entry point above every stage, as the
console script is; nothing imports it)."""

import sys

from wheelrom.cli.main import main

if __name__ == "__main__":
    sys.exit(main())
