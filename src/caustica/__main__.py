"""``python -m caustica``: the same command line as the ``caustica`` script."""
import sys

from .cli import main

sys.exit(main())
