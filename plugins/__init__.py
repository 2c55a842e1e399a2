"""postproc's built-in compensators, installed as the package ``postproc_plugins``.

Each module is one compensator, registered through the ``postproc`` entry-point group
exactly as a third-party compensator is.
"""
