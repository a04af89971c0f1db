"""``python -m studies.report``: writes results/effects.csv, results/README.md and the report's figures."""
import sys

from . import main

sys.exit(main(sys.argv[1:]))
