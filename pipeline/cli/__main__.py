"""``python -m pipeline.cli``: the ``shellvox`` command without the installed script."""

from __future__ import annotations

import sys

from pipeline.cli import main

sys.exit(main())
