"""``python -m slidingarm``: the command-line interface."""

from slidingarm.cli import script

if __name__ == "__main__":
    script()
