"""Names of the orientation algorithms, importable without numpy or numba.

The command line lists them in its ``--help``, which must not load the compiled kernels.
"""

#: Algorithm names of the command line and the bench: name -> (propagation, corrections on).
ALGORITHMS: dict[str, tuple[str, bool]] = {
    "ekf-taylor3": ("taylor3", True),
    "ekf-rk4": ("rk4", True),
    "taylor3": ("taylor3", False),
    "rk4": ("rk4", False),
}
