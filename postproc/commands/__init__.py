"""Commands of the postproc command line, one per module; cli.py registers them."""
