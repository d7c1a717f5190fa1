import sys

from coordinator.process import main

sys.exit(main())
