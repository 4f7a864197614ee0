"""The seeds' papers on top of the library: per seed its scenes with the seed's values,
the numbers it prints (stored once, with their source), its studies and figures, and
:mod:`pipeflex.seeds.validate`, which recomputes and compares them.

The library (everything in :mod:`pipeflex` outside this package) imports nothing from here.
"""
