"""The seam work of the discrete solver (kwatra2003 §3): what it does with the pieces it copies
between its iterations (:mod:`.pieces`: copy-size control, border seams, the state's shift),
the graph cuts of straight seams (:mod:`.cuts`), the expansion moves (:mod:`.expansion`,
boykov2001), the gradient-domain blend of the seams left (:mod:`.gradient`, perez2003) and
their numba kernels (:mod:`._kernels`).

Used within :mod:`barkgen.synth` only; other packages reach these through
:mod:`barkgen.synth`'s face. Nothing is imported here, so that a module of the solver's core
may import one of these without running the package's face.
"""
