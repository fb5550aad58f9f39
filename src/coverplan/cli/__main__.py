import sys

from coverplan.cli.main import main

sys.exit(main())
