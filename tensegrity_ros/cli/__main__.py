import sys

from tensegrity_ros.cli import main

sys.exit(main())
