"""Public helpers compensators build on: error functions, trace inversion, probed chains.

They see the contract and the measurements, never the engine (the import-linter contract
``plugins-see-the-contract`` in pyproject.toml).
"""
