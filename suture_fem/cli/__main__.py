"""``python -m suture_fem.cli``: the same as the ``suture-fem`` command."""

import sys

from suture_fem.cli.main import main

sys.exit(main())
