"""The command line: ``main`` defines ``postproc`` and its options; every other command has its own module.

The console script is ``postproc.cli.main:main``; ``python -m postproc`` runs the same ``main``.
"""
