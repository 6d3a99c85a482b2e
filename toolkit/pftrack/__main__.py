import sys

from pftrack.cli import main

sys.exit(main())
