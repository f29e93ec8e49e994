"""``python -m blockhash``: the ``blockhash`` command line (:mod:`blockhash.cli`)."""

import sys

from blockhash.cli import main

sys.exit(main())
