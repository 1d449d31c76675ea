"""``python -m mjsuff.cli``: the same as the ``mjsuff`` command."""

import sys

from mjsuff.cli import main

sys.exit(main())
