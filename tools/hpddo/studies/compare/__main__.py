"""python -m hpddo.studies.compare DIR: the markdown tables of docs/compare.md from a run's JSON files."""
import sys

from .text import main

sys.exit(main())
