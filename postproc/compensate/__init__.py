"""Moves to a corrected program: the compensator contract, its registry, the rewriter, the segmenter, the emitter.

The contract (:mod:`.compensator`, :mod:`.hookspecs`) is public at its documented paths
``postproc.compensator`` and ``postproc.hookspecs`` too. This package's ``__init__`` imports
nothing, so that importing the contract loads no engine module.
"""
