"""``python -m dronefleet.cli``: the ``dronefleet`` command."""

import sys

from dronefleet.cli import main

sys.exit(main())
