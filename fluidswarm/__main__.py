import sys

from fluidswarm.cli import main

sys.exit(main())
