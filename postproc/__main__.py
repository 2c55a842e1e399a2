"""``python -m postproc``: the same command line as the ``postproc`` console script."""

from .cli.main import main

if __name__ == "__main__":
    main(prog_name="postproc")
