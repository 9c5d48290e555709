"""``python -m slidingarm``: the command-line interface."""

from slidingarm.cli import main

if __name__ == "__main__":
    main()
