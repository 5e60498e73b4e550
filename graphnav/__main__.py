import sys

from graphnav.cli import main

sys.exit(main())
