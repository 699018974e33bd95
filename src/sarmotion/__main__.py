"""``python -m sarmotion``: the command line without the console script."""

from .cli import entry_point

if __name__ == "__main__":
    entry_point()
