import sys

from latent_planner_ros.cli import main

sys.exit(main())
