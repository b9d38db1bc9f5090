"""`python -m pendkit.cli ...` is `pendkit ...` (Gradescope's run_autograder calls it this way)."""

import sys

from pendkit.cli import main

sys.exit(main())
