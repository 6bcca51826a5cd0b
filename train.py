"""Train a PPO or SAC agent on an ios_uav_env id: ``python train.py --help`` (see agents/cli.py)."""

import sys

from agents.cli import main

if __name__ == "__main__":
    sys.exit(main())
