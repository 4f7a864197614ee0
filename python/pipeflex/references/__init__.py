"""Reference solutions written independently of pipeflex's finite elements, to check them.

:mod:`pipeflex.references.continuous_pipe`: the cantilevered pipe conveying fluid as a
continuous beam (its characteristic determinant), for the stability map.
"""
