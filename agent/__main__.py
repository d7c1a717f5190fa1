import sys

from agent.process import main

sys.exit(main())
