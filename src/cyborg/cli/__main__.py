"""``python -m cyborg.cli``: the command line (how a launch starts its nodes)."""

from cyborg.cli import main

if __name__ == "__main__":
    main()
