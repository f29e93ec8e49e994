"""``python -m blockhash.cli``: the command line, as ``blockhash`` and ``python -m blockhash`` run
it (the GPU machine's runner calls it so)."""

import sys

from blockhash.cli import main

if __name__ == "__main__":
    sys.exit(main())
