"""``python -m mjsuff.cli``: the same as the ``mjsuff`` command."""

import sys

from mjsuff.cli.main import main

sys.exit(main())
