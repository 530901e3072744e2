import sys

from certiloop.proofs.cli.main import main

sys.exit(main())
